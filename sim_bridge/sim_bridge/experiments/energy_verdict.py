"""A stability verdict from energy and motion, in windows sized by the round-trip delay (docs/RESULTS.md).

The older criterion (sim_bridge.experiments.stability) judges only e = x_d - x_R after a 0.5 s centred detrend,
which removes most of a 2-4 s oscillation -- the period a loop closed through 0.5-1 s of delay oscillates at --
while counting the operator's fast moves as oscillation. This one judges what an unstable teleoperator shows:

1. ENERGY. The mechanical energy of the loop, E(t) = the replica arm's kinetic energy 1/2 qd^T M(q) qd + the
   handle's 1/2 m_h |v_M|^2 (+ any port storage the caller adds: the attractor's, the channel's), is not allowed
   to grow: over the judged span the peak of E in the LAST window must not exceed ``growth_ratio`` times the peak
   of the FIRST judged window while above ``energy_floor``. A delayed loop with too little damping gains energy
   every cycle (Anderson and Spong 1989, "Bilateral control of teleoperators with time delay"), so its window
   peaks grow.
2. MOTION. x_M (the handle), x_d (the replica's set point) and x_R (the replica's TCP), each with the caller's
   known commanded motion removed (the planner's trajectory in x_d and x_R: a commanded circle is not an
   oscillation), must not oscillate in a sustained way: in EVERY judged window, after removing the window's
   linear trend, an axis whose amplitude (half the peak-to-peak) exceeds ``oscillation_amplitude`` AND whose
   normalised autocorrelation has a peak above ``periodicity`` at a lag in [``min_period``, 4 x round-trip delay]
   means a self-sustained periodic motion (the autocorrelation is taken over the whole judged span, so a period
   of 4 round trips has a full period of overlap; the amplitude must be there in every window). An operator's
   aperiodic moves do not repeat at one lag; a limit cycle does, and a limit cycle that does not grow (saturated
   by F_max, say) is caught here when test 1 passes.
3. ERROR (when given): |x_d - x_R| stays within ``error_bound`` (4 x_b) over the judged span; a bounded runaway
   neither grows nor repeats.
4. PORTS (when given). The channel's generated energy (what left it at both ports minus what entered, the
   time-domain passivity observers' sum, sim_bridge.experiments.channel_ports) is taken as its peak per judged
   window: a delay that feeds a loop more energy every cycle shows peaks that grow, so a last window's peak
   above ``growth_ratio`` times the first window's (or the ``energy_floor``, whichever is larger) is unstable. A
   steady generation (a delayed loop driven by its operator, the surplus damped away) grows by the windows'
   length over the run's, far below that ratio; it is reported, not judged. The task-space port's
   passivity margin (fic_core.passivity_observer) is reported (its smallest value and its fall over the judged
   span), not judged: the linear baselines' margin falls by design (their damping's work is not in their storage).

Windows: W = max(``min_window``, 4 x the round-trip delay), long enough to hold one full period of the slowest
oscillation a loop through that delay shows (a delay-induced oscillation has a period of at most about 4 round
trips: its phase lag of pi/2 to pi accrues over one round trip). The judged span is the last ``judged_windows``
windows after ``settle`` seconds; a run too short for that is NOT ASSESSED (``assessed`` False, ``stable`` None),
rather than judged on too little.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray


class VerdictInputError(ValueError):
    """Time series that cannot be judged (shape, NaN, time not increasing)."""


@dataclass(frozen=True)
class EnergyMotionCriterion:
    round_trip_delay: float                 # [s] forward + backward delay of the channel
    min_window: float = 2.0                 # [s] the shortest window (fast loops)
    judged_windows: int = 2                 # windows at the end of the run that are judged
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
    judged_from: float                      # [s] start of the judged span
    energy_window_peaks: list[float]        # [J] per judged window
    energy_growth: float                    # last / first judged window peak
    energy_peak: float                      # [J] over the run
    signals: dict[str, SignalOscillation] = field(default_factory=dict)
    criterion: dict = field(default_factory=dict)
    ports: dict = field(default_factory=dict)   # test 4's figures (module docstring); empty when not given

    def as_dict(self) -> dict:
        values = asdict(self)
        if not np.isfinite(values["energy_growth"]):
            values["energy_growth"] = None
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
    peaks = [i for i in range(1, lags.size - 1) if unbiased[i] >= unbiased[i - 1] and unbiased[i] >= unbiased[i + 1]]
    if not peaks:
        return 0.0, 0.0
    best = max(peaks, key=lambda i: unbiased[i])
    return float(unbiased[best]), float(lags[best] * step)


def _oscillation(time: NDArray, values: NDArray, edges: NDArray, criterion: EnergyMotionCriterion
                 ) -> SignalOscillation:
    """Amplitude per window (after its own linear trend); periodicity over the whole judged span, so that a lag of
    up to 4 round trips (half the span of two windows) has a full period of overlap."""
    step = float(np.median(np.diff(time)))
    span = (time >= edges[0]) & (time < edges[-1])
    rest = _detrended(time[span], values[span])
    periodic = [_autocorrelation_peak(rest[:, axis], step, criterion.min_period, criterion.max_period)
                for axis in range(rest.shape[1])]
    amplitudes = []
    for low, high in zip(edges[:-1], edges[1:]):
        inside = (time >= low) & (time < high)
        window_rest = _detrended(time[inside], values[inside])
        amplitudes.append(0.5 * np.ptp(window_rest, axis=0))
    # An axis oscillates when it is large in every window and periodic over the span.
    per_axis = [all(a[axis] > criterion.oscillation_amplitude for a in amplitudes)
                and periodic[axis][0] > criterion.periodicity for axis in range(rest.shape[1])]
    chosen = int(np.argmax([periodic[axis][0] if min(a[axis] for a in amplitudes) > criterion.oscillation_amplitude
                            else -1.0 + min(a[axis] for a in amplitudes) for axis in range(rest.shape[1])]))
    return SignalOscillation([float(a[chosen]) for a in amplitudes], periodic[chosen][0], periodic[chosen][1],
                             any(per_axis))


def _ports(time: NDArray, edges: NDArray, channel_generated: ArrayLike | None, passivity_margin: ArrayLike | None
           ) -> dict:
    """Test 4's figures: the channel's generation per judged window and its growth, the margin's minimum and fall."""
    ports: dict = {}
    if channel_generated is not None:
        generated = _rows("channel_generated", time, channel_generated)[:, 0]
        peaks = [float(generated[(time >= low) & (time < high)].max()) for low, high in zip(edges[:-1], edges[1:])]
        ports.update(channel_generated_total_j=float(generated[-1]), channel_generated_window_peaks_j=peaks,
                     channel_generation_growth=peaks[-1] / peaks[0] if peaks[0] > 0.0 else None)
    if passivity_margin is not None:
        margin = _rows("passivity_margin", time, passivity_margin)[:, 0]
        span = margin[time >= edges[0]]
        ports.update(passivity_margin_min_j=float(margin.min()),
                     passivity_margin_fall_in_judged_span_j=float(span[0] - span.min()))
    return ports


def assess_energy_motion(time: ArrayLike, *, energy: ArrayLike, motion: dict[str, ArrayLike],
                         criterion: EnergyMotionCriterion, error: ArrayLike | None = None,
                         channel_generated: ArrayLike | None = None,
                         passivity_margin: ArrayLike | None = None) -> EnergyMotionVerdict:
    """Judge one run (module docstring). time (n,) [s] on a near-uniform grid; energy (n,) [J], the loop's
    mechanical energy (plus port storage); motion: name -> (n, k) positions [m] with commanded motion removed;
    error (n, 3) [m], x_d - x_R, optional: beyond ``error_bound`` in the judged span the replica has run away (a
    bounded runaway -- an arm held against the scene by a 10 Hz torque loop -- neither grows nor repeats);
    channel_generated (n,) [J], the channel's generated energy so far, and passivity_margin (n,) [J], the
    task-space port's margin, optional (test 4)."""
    time = _time(time)
    energy_values = _rows("energy", time, energy)[:, 0]
    signals = {name: _rows(name, time, values) for name, values in motion.items()}
    window = criterion.window
    judged_from = time[-1] - criterion.judged_windows * window
    edges = judged_from + window * np.arange(criterion.judged_windows + 1)
    reasons: list[str] = []
    finite = bool(np.all(np.isfinite(energy_values))) and all(np.all(np.isfinite(v)) for v in signals.values())
    peak = float(np.nanmax(np.abs(energy_values))) if np.any(np.isfinite(energy_values)) else float("inf")
    if not finite:
        reasons.append("NaN or Inf in the energy or the motion")
    if peak > criterion.energy_bound:
        reasons.append(f"mechanical energy {peak:.3g} J above the bound {criterion.energy_bound:g} J")
    if judged_from < time[0] + criterion.settle:
        return EnergyMotionVerdict(bool(reasons), False if reasons else None, reasons or [
            f"not assessed: {criterion.judged_windows} windows of {window:.2f} s after {criterion.settle:g} s of "
            f"settling need {criterion.settle + criterion.judged_windows * window:.2f} s, the run has "
            f"{time[-1] - time[0]:.2f} s"], window, float(judged_from), [], float("nan"), peak,
            criterion=asdict(criterion))
    if not finite:
        return EnergyMotionVerdict(True, False, reasons, window, float(judged_from), [], float("inf"), peak,
                                   criterion=asdict(criterion))
    window_peaks = []
    for low, high in zip(edges[:-1], edges[1:]):
        inside = (time >= low) & (time < high)
        window_peaks.append(float(np.max(energy_values[inside])))
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
    ports = _ports(time, edges, channel_generated, passivity_margin)
    if channel_generated is not None:
        peaks = ports["channel_generated_window_peaks_j"]
        if peaks[-1] > criterion.growth_ratio * max(peaks[0], criterion.energy_floor):
            reasons.append(f"the channel's generated energy growing: window peak {peaks[-1] * 1e3:.3g} mJ against "
                           f"{peaks[0] * 1e3:.3g} mJ in the first judged window (limit {criterion.growth_ratio:g}x)")
    oscillations = {name: _oscillation(time, values, edges, criterion) for name, values in signals.items()}
    for name, result in oscillations.items():
        if result.sustained:
            reasons.append(f"sustained oscillation of {name}: amplitude {min(result.amplitude) * 1e3:.1f} mm or more, "
                           f"periodic at {result.period:.2f} s (autocorrelation {result.periodicity:.2f}) in every {window:.2f} s window")
    return EnergyMotionVerdict(True, not reasons, reasons, window, float(judged_from), window_peaks, float(growth),
                               peak, oscillations, asdict(criterion), ports)
