"""A stability verdict from energy and motion, in windows sized by the round-trip delay (docs/EXPERIMENTS.md).

The older criterion (fic_teleop_experiments.stability) judges only e = x_d - x_R after a 0.5 s centred detrend,
which removes most of a 2-4 s oscillation -- the period a loop closed through 0.5-1 s of delay oscillates at --
while counting the operator's fast moves as oscillation. This one judges what an unstable teleoperator shows:

1. ENERGY. The mechanical energy of the loop, E(t) = the replica arm's kinetic energy 1/2 qd^T M(q) qd + the
   handle's 1/2 m_h |v_M|^2 (+ any port storage the caller adds: the attractor's, the channel's), is not allowed
   to grow: over the judged span the peak of E in the LAST window must not exceed ``growth_ratio`` times the peak
   of the FIRST judged window while above ``energy_floor``. A delayed loop with too little damping gains energy
   every cycle (Anderson and Spong 1989, "Bilateral control of teleoperators with time delay"), so its window
   peaks grow.
2. MOTION. x_M (the handle), x_d (the replica's set point) and x_R (the replica's TCP), each with the caller's
   known commanded motion removed (the operator's target in x_M; the planner's trajectory and that target one delay
   later in x_d and x_R: a commanded circle is not an oscillation), must not oscillate in a sustained way. A loop
   driven by a periodic task answers it with a motion that is not its command (the hand gives way to the force it
   feels, the replica lags the delayed command) and, when the loop is stable, repeats at the task's period: with
   ``task_period`` set (E1's 5 s lap) the motion judged is what differs from lap to lap, the motion minus its median
   at the same phase of the lap (fic_teleop_experiments.lap_median), over the span after settling, one lap and one round
   trip (EnergyMotionCriterion.lap_start) and only when that span holds ``min_laps`` laps. Then in EVERY judged
   window, after removing the window's linear trend, an axis whose amplitude (half the peak-to-peak) exceeds
   ``oscillation_amplitude`` AND whose normalised autocorrelation has a peak above ``periodicity`` at a lag in
   [``min_period``, 4 x round-trip delay] means a self-sustained periodic motion. The autocorrelation is taken over
   the whole motion span, so that a period of 4 round trips has a full period of overlap when the span holds two
   windows (the lags reached are reported, ``max_period_judged``), and a peak counts only after the autocorrelation
   has first fallen to zero: a repeating motion decorrelates within its period, a slow drift with a ripple on it
   does not (its short-lag maxima are the drift's, not a period). An operator's aperiodic moves do not repeat at
   one lag; a limit cycle does, and a limit cycle that does not grow (saturated by F_max, say) is caught here when
   test 1 passes. Not seen, stated: a steady oscillation locked to a multiple of the lap's frequency (it repeats at
   the lap as the task's answer does); a growing one changes from lap to lap, and test 1 judges growth anyway.
3. ERROR (when given): |x_d - x_R| stays within ``error_bound`` (4 x_b) over the judged span; a bounded runaway
   neither grows nor repeats.
4. PORTS (when given). The channel's generated energy (what left it at both ports minus what entered, the
   time-domain passivity observers' sum, fic_core.channel_ports) is taken as its peak per judged
   window: a delay that feeds a loop more energy every cycle shows peaks that grow, so a last window's peak
   above ``growth_ratio`` times the first window's (or the ``energy_floor``, whichever is larger) is unstable. A
   steady generation (a delayed loop driven by its operator, the surplus damped away) grows by the windows'
   length over the run's, far below that ratio; it is reported, not judged. The task-space port's
   passivity margin (fic_core.passivity_observer) is reported (its smallest value and its fall over the judged
   span), not judged: the linear baselines' margin falls by design (their damping's work is not in their storage).

Windows: W = max(``min_window``, 4 x the round-trip delay), long enough to hold one full period of the slowest
oscillation a loop through that delay shows (a delay-induced oscillation has a period of at most about 4 round
trips: its phase lag of pi/2 to pi accrues over one round trip). The energy span (tests 1, 3, 4) is the last
``judged_windows`` windows after ``settle`` seconds; the motion span (test 2) the same after ``lap_start``. A run
whose energy span holds fewer than ``judged_windows`` windows but at least ``min_span_windows`` (1.5) has its
windows spread over it, overlapping (``windows_overlap``): at 2 s each way a 30 s run holds 29 s after settling, two
16 s windows 13 s apart. A run shorter than that, with fewer than ``min_laps`` laps after ``lap_start``, or a motion
span under one window, is NOT ASSESSED (``assessed`` False, ``stable`` None), rather than judged on too little.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_teleop_experiments.lap_median import without_lap_median


class VerdictInputError(ValueError):
    """Time series that cannot be judged (shape, NaN, time not increasing)."""


@dataclass(frozen=True)
class EnergyMotionCriterion:
    round_trip_delay: float                 # [s] forward + backward delay of the channel
    # [s] the task's own period (E1's 5 s lap), None for an aperiodic task: the motion test judges the motion minus
    # its median at the same phase of the lap (fic_teleop_experiments.lap_median), the task's forced response removed.
    task_period: float | None = None
    min_window: float = 2.0                 # [s] the shortest window (fast loops)
    judged_windows: int = 2                 # windows at the end of the run that are judged
    min_span_windows: float = 1.5           # the energy span must hold this many windows (they overlap below 2)
    min_laps: float = 2.0                   # laps the lap median is taken over (fewer: the median is the motion itself)
    settle: float = 1.0                     # [s] start-up left out before the judged span may begin
    growth_ratio: float = 2.0               # last window's energy peak over the first judged window's
    energy_floor: float = 2.5e-3            # [J] below it nothing counts as growing (1/2 200 N/m (5 mm)^2)
    oscillation_amplitude: float = 0.005    # [m] half peak-to-peak an oscillating axis must exceed (x_b / 10)
    periodicity: float = 0.5                # autocorrelation peak that makes a motion periodic
    min_period: float = 0.2                 # [s] faster "oscillation" is contact chatter, judged by test 1 only
    energy_bound: float = 50.0              # [J] beyond it the run has run away whatever the windows say
    error_bound: float = 0.20               # [m] |x_d - x_R| over the judged span; 4 x_b (x_b = 0.05 m)

    @property
    def window(self) -> float:
        return max(self.min_window, 4.0 * self.round_trip_delay)

    @property
    def max_period(self) -> float:
        return max(4.0 * self.round_trip_delay, 2.0 * self.min_period)

    def lap_start(self, first_sample: float) -> float:
        """Where the task's response can repeat: after the settling, one lap (the task's first differs: it starts
        from rest, E1's pushable obstacle is swept) and one round trip (that lap's command has reached the replica
        and its force has come back)."""
        if self.task_period is None:
            return first_sample + self.settle
        return first_sample + self.settle + self.task_period + self.round_trip_delay


@dataclass
class SignalOscillation:
    amplitude: list[float]                  # [m] per judged window, of the most oscillating axis
    periodicity: float                      # that axis' autocorrelation peak in the lag band over the judged span
    period: float                           # [s] lag of that peak (0 when none)
    sustained: bool


@dataclass
class EnergyMotionVerdict:
    assessed: bool
    stable: bool | None                     # None when not assessed
    reasons: list[str]
    window: float                           # [s]
    judged_from: float                      # [s] start of the energy span (tests 1, 3, 4)
    energy_window_peaks: list[float]        # [J] per judged window
    energy_growth: float                    # last / first judged window peak
    energy_peak: float                      # [J] over the run
    signals: dict[str, SignalOscillation] = field(default_factory=dict)
    criterion: dict = field(default_factory=dict)
    ports: dict = field(default_factory=dict)   # test 4's figures (module docstring); empty when not given
    motion_judged_from: float = float("nan")   # [s] start of the motion span (test 2)
    windows_overlap: float = 0.0            # [s] the judged windows overlap by this much (a run under 2 windows)
    max_period_judged: float = 0.0          # [s] longest period the motion span's autocorrelation reaches
    laps_in_lap_median: float = 0.0           # laps the task's typical motion was taken over (0: no task period)

    def as_dict(self) -> dict:
        values = asdict(self)
        for key in ("energy_growth", "motion_judged_from"):
            if not np.isfinite(values[key]):
                values[key] = None
        return values


def _time(values: ArrayLike) -> NDArray[np.float64]:
    time = np.asarray(values, dtype=np.float64)
    if time.ndim != 1 or time.size < 8 or not np.all(np.isfinite(time)) or np.any(np.diff(time) <= 0.0):
        raise VerdictInputError("time must be a finite, strictly increasing 1-D array of at least 8 samples")
    return time


def _rows(name: str, time: NDArray, values: ArrayLike) -> NDArray[np.float64]:
    array = np.asarray(values, dtype=np.float64)
    if array.ndim == 1:
        array = array[:, None]
    if array.ndim != 2 or array.shape[0] != time.size:
        raise VerdictInputError(f"{name} must have {time.size} rows, got shape {array.shape}")
    return array


def _detrended(time: NDArray, values: NDArray) -> NDArray:
    """``values`` minus their least-squares line, per column."""
    centred = time - time.mean()
    design = np.column_stack([np.ones_like(centred), centred])
    coefficients, *_ = np.linalg.lstsq(design, values, rcond=None)
    return values - design @ coefficients


def _autocorrelation_peak(values: NDArray, step: float, min_lag: float, max_lag: float) -> tuple[float, float]:
    """(largest local maximum of the normalised autocorrelation in [min_lag, max_lag], its lag [s])."""
    n = values.size
    energy = float(np.dot(values, values))
    if energy <= 0.0:
        return 0.0, 0.0
    spectrum = np.fft.rfft(values, 2 * n)
    correlation = np.fft.irfft(spectrum * np.conj(spectrum))[:n] / energy
    # Unbiased for the overlap (n - lag samples), but only up to half the window: beyond it too few samples overlap.
    low, high = int(np.ceil(min_lag / step)), min(int(max_lag / step), n // 2)
    if high <= low + 1:
        return 0.0, 0.0
    lags = np.arange(low, high + 1)
    unbiased = correlation[lags] * n / (n - lags)
    # A repeating motion decorrelates within its period (a sine's autocorrelation is negative from a quarter to
    # three quarters of it) and correlates again at the period; a slow drift stays correlated at short lags, where a
    # ripple on it makes local maxima. Only a maximum after the autocorrelation has first fallen to zero is a period.
    everywhere = correlation[:high + 1] * n / (n - np.arange(high + 1))
    crossed = np.nonzero(everywhere <= 0.0)[0]
    if crossed.size == 0:
        return 0.0, 0.0
    first = max(1, int(crossed[0]) - low)
    peaks = [i for i in range(first, lags.size - 1)
             if unbiased[i] >= unbiased[i - 1] and unbiased[i] >= unbiased[i + 1]]
    if not peaks:
        return 0.0, 0.0
    best = max(peaks, key=lambda i: unbiased[i])
    return float(unbiased[best]), float(lags[best] * step)


def _windows(start: float, stop: float, criterion: EnergyMotionCriterion) -> list[tuple[float, float]]:
    """``judged_windows`` windows of length W in [start, stop]: end to end from ``stop`` back when the span holds
    them, else spread evenly from ``start`` to ``stop`` (so they overlap; the first and the last are still
    stop - start - W apart)."""
    window, count = criterion.window, criterion.judged_windows
    if stop - start >= count * window:
        first = stop - count * window
        return [(first + k * window, first + (k + 1) * window) for k in range(count)]
    return [(low, low + window) for low in np.linspace(start, stop - window, count)]


def _inside(time: NDArray, low: float, high: float, last: bool) -> NDArray:
    """Samples of [low, high) ([low, high] for the run's last window, so its last sample counts)."""
    return (time >= low) & ((time <= high) if last else (time < high))


def _oscillation(time: NDArray, values: NDArray, windows: list[tuple[float, float]], criterion: EnergyMotionCriterion
                 ) -> SignalOscillation:
    """Amplitude per window (after its own linear trend); periodicity over the whole motion span, so that a lag of
    up to 4 round trips (half the span of two windows) has a full period of overlap."""
    step = float(np.median(np.diff(time)))
    span = _inside(time, windows[0][0], windows[-1][1], True)
    rest = _detrended(time[span], values[span])
    periodic = [_autocorrelation_peak(rest[:, axis], step, criterion.min_period, criterion.max_period)
                for axis in range(rest.shape[1])]
    amplitudes = []
    for index, (low, high) in enumerate(windows):
        inside = _inside(time, low, high, index == len(windows) - 1)
        window_rest = _detrended(time[inside], values[inside])
        amplitudes.append(0.5 * np.ptp(window_rest, axis=0))
    # An axis oscillates when it is large in every window and periodic over the span.
    per_axis = [all(a[axis] > criterion.oscillation_amplitude for a in amplitudes)
                and periodic[axis][0] > criterion.periodicity for axis in range(rest.shape[1])]
    chosen = int(np.argmax([periodic[axis][0] if min(a[axis] for a in amplitudes) > criterion.oscillation_amplitude
                            else -1.0 + min(a[axis] for a in amplitudes) for axis in range(rest.shape[1])]))
    return SignalOscillation([float(a[chosen]) for a in amplitudes], periodic[chosen][0], periodic[chosen][1],
                             any(per_axis))


def _ports(time: NDArray, windows: list[tuple[float, float]], channel_generated: ArrayLike | None,
           passivity_margin: ArrayLike | None) -> dict:
    """Test 4's figures: the channel's generation per judged window and its growth, the margin's minimum and fall."""
    ports: dict = {}
    if channel_generated is not None:
        generated = _rows("channel_generated", time, channel_generated)[:, 0]
        peaks = [float(generated[_inside(time, low, high, k == len(windows) - 1)].max())
                 for k, (low, high) in enumerate(windows)]
        ports.update(channel_generated_total_j=float(generated[-1]), channel_generated_window_peaks_j=peaks,
                     channel_generation_growth=peaks[-1] / peaks[0] if peaks[0] > 0.0 else None)
    if passivity_margin is not None:
        margin = _rows("passivity_margin", time, passivity_margin)[:, 0]
        span = margin[time >= windows[0][0]]
        ports.update(passivity_margin_min_j=float(margin.min()),
                     passivity_margin_fall_in_judged_span_j=float(span[0] - span.min()))
    return ports


def assess_energy_motion(time: ArrayLike, *, energy: ArrayLike, motion: dict[str, ArrayLike],
                         criterion: EnergyMotionCriterion, error: ArrayLike | None = None,
                         channel_generated: ArrayLike | None = None,
                         passivity_margin: ArrayLike | None = None) -> EnergyMotionVerdict:
    """Judge one run (module docstring). time (n,) [s] on a near-uniform grid; energy (n,) [J], the loop's
    mechanical energy (plus port storage); motion: name -> (n, k) positions [m] with commanded motion removed (the
    task's periodic response is removed here when ``criterion.task_period`` is set); error (n, 3) [m], x_d - x_R,
    optional: beyond ``error_bound`` in the judged span the replica has run away (a bounded runaway -- an arm held
    against the scene by a 10 Hz torque loop -- neither grows nor repeats); channel_generated (n,) [J], the
    channel's generated energy so far, and passivity_margin (n,) [J], the task-space port's margin, optional
    (test 4)."""
    time = _time(time)
    energy_values = _rows("energy", time, energy)[:, 0]
    signals = {name: _rows(name, time, values) for name, values in motion.items()}
    window = criterion.window
    end = float(time[-1])
    judged_from = max(float(time[0]) + criterion.settle, end - criterion.judged_windows * window)
    # The motion span starts where the task's response can repeat (EnergyMotionCriterion.lap_start).
    motion_from = max(criterion.lap_start(float(time[0])), end - criterion.judged_windows * window)
    reasons: list[str] = []
    finite = bool(np.all(np.isfinite(energy_values))) and all(np.all(np.isfinite(v)) for v in signals.values())
    peak = float(np.nanmax(np.abs(energy_values))) if np.any(np.isfinite(energy_values)) else float("inf")
    if not finite:
        reasons.append("NaN or Inf in the energy or the motion")
    if peak > criterion.energy_bound:
        reasons.append(f"mechanical energy {peak:.3g} J above the bound {criterion.energy_bound:g} J")
    short = []
    if end - judged_from < criterion.min_span_windows * window:
        short.append(f"{criterion.min_span_windows:g} windows of {window:.2f} s after {criterion.settle:g} s of "
                     f"settling need {criterion.settle + criterion.min_span_windows * window:.2f} s")
    laps = 0.0
    if signals and criterion.task_period is not None:
        laps = (end - criterion.lap_start(float(time[0]))) / criterion.task_period
        if laps < criterion.min_laps:
            short.append(f"the task's lap median over {criterion.min_laps:g} laps of {criterion.task_period:g} s after "
                         f"{criterion.lap_start(0.0):.2f} s needs "
                         f"{criterion.lap_start(0.0) + criterion.min_laps * criterion.task_period:.2f} s")
    if signals and end - motion_from < window:
        short.append(f"a {window:.2f} s motion window after {motion_from - float(time[0]):.2f} s needs "
                     f"{motion_from - float(time[0]) + window:.2f} s")
    if short:
        return EnergyMotionVerdict(bool(reasons), False if reasons else None, reasons or [
            "not assessed: " + "; ".join(short) + f", the run has {end - time[0]:.2f} s"], window,
            float(judged_from), [], float("nan"), peak, criterion=asdict(criterion))
    if not finite:
        return EnergyMotionVerdict(True, False, reasons, window, float(judged_from), [], float("inf"), peak,
                                   criterion=asdict(criterion))
    windows = _windows(judged_from, end, criterion)
    window_peaks = [float(np.max(energy_values[_inside(time, low, high, k == len(windows) - 1)]))
                    for k, (low, high) in enumerate(windows)]
    growth = window_peaks[-1] / window_peaks[0] if window_peaks[0] > 0.0 else (
        float("inf") if window_peaks[-1] > 0.0 else 1.0)
    if window_peaks[-1] > criterion.energy_floor and growth > criterion.growth_ratio:
        reasons.append(f"mechanical energy growing: window peak {window_peaks[-1] * 1e3:.3g} mJ is {growth:.1f}x "
                       f"the first judged window's (limit {criterion.growth_ratio:g}x)")
    if error is not None:
        magnitude = np.linalg.norm(_rows("error", time, error), axis=1)[time >= judged_from]
        if float(magnitude.max()) > criterion.error_bound:
            reasons.append(f"tracking error {magnitude.max() * 1e3:.0f} mm in the judged span, above the bound "
                           f"{criterion.error_bound * 1e3:.0f} mm")
    ports = _ports(time, windows, channel_generated, passivity_margin)
    if channel_generated is not None:
        peaks = ports["channel_generated_window_peaks_j"]
        if peaks[-1] > criterion.growth_ratio * max(peaks[0], criterion.energy_floor):
            reasons.append(f"the channel's generated energy growing: window peak {peaks[-1] * 1e3:.3g} mJ against "
                           f"{peaks[0] * 1e3:.3g} mJ in the first judged window (limit {criterion.growth_ratio:g}x)")
    motion_windows = _windows(motion_from, end, criterion)
    if criterion.task_period is not None:
        lap_from = criterion.lap_start(float(time[0]))
        signals = {name: without_lap_median(time, values, criterion.task_period, lap_from)
                   for name, values in signals.items()}
    oscillations = {name: _oscillation(time, values, motion_windows, criterion) for name, values in signals.items()}
    what = "lap-to-lap motion" if criterion.task_period is not None else "motion"
    for name, result in oscillations.items():
        if result.sustained:
            reasons.append(f"sustained oscillation of {name} ({what}): amplitude {min(result.amplitude) * 1e3:.1f} mm "
                           f"or more, periodic at {result.period:.2f} s (autocorrelation {result.periodicity:.2f}) in "
                           f"every {window:.2f} s window")
    motion_span = motion_windows[-1][1] - motion_windows[0][0]
    return EnergyMotionVerdict(
        True, not reasons, reasons, window, float(judged_from), window_peaks, float(growth), peak, oscillations,
        asdict(criterion), ports, motion_judged_from=float(motion_from),
        windows_overlap=max(0.0, windows[0][1] - windows[1][0]) if len(windows) > 1 else 0.0,
        max_period_judged=min(criterion.max_period, 0.5 * motion_span), laps_in_lap_median=float(laps))
