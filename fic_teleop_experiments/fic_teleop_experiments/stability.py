"""The sweep stability criterion (docs/EXPERIMENTS.md), stated precisely and computed from time series.

A run is judged on its LAST HALF, ``[T/2, T]`` with ``T`` the last sample time (the first half is left to start-up
transients). It is STABLE when all four tests pass:

1. No limit violation: the replica's cumulative ``LimitStatus.violation_ticks`` counter does not increase over the
   last half (a tick whose command or measured state broke a Panda limit, docs/CONTROL_LAWS.md).
2. Bounded tracking error: ``max |e(t)| <= error_bound`` over the last half, with ``e = x_d - x_R`` the TCP
   position error (x_d including the planner's motion). Default bound 0.20 m = 4 x_b (x_b = 0.05 m, paper
   Sec. III): the scripted tasks never command the TCP more than about 0.11 m into a rigid obstacle (half an
   obstacle plus the end-effector plate), so an error beyond 4 x_b means the replica has run away, not that it is
   pressing on something.
3. Oscillation energy not growing. The oscillatory part of the motion is the error minus its centred moving
   average over ``detrend_window`` (0.5 s: the operator's ramps and the 5 s circle are slower and are removed),
   ``e_osc = e - mean_0.5s(e)``; its mechanical energy is that of the controller's spring and a nominal TCP mass
   carrying it, ``E_osc = 1/2 K0 |e_osc|^2 + 1/2 m |de_osc/dt|^2`` (K0 = 200 N/m, m = 4 kg: the numbers
   config/replica.yaml uses for the baseline's damping). The third and the fourth quarter of the run are cut into
   windows (``oscillation_window``, 1 s, or a quarter/4 in runs shorter than 16 s); the energy is GROWING when the median of
   the per-window peak energies of the fourth quarter exceeds ``growth_ratio`` (2) times that of the third quarter
   AND exceeds ``energy_floor`` (the energy of a 5 mm oscillation, 1/2 K0 (0.005 m)^2 = 2.5 mJ, below which
   there is nothing to grow), AND the fourth quarter shows ``min_cycles`` (3) cycles of oscillation: at least
   2 x 3 sign alternations of an e_osc axis between beyond +h and beyond -h, h = oscillation_amplitude / 2.
   Medians, not the peak, and cycles, not edges: a contact that starts or ends in the last quarter is a step of
   the error, which the detrending turns into ONE alternation, not an oscillation. With force data, only the
   free-motion windows of each quarter are compared when each quarter has at least 2 (an impact burst in the
   last quarter of a contact task is the environment's doing); otherwise all windows.
4. No sustained oscillation IN FREE MOTION: among the last half's windows spent in free motion (docs/EXPERIMENTS.md: the F/T
   force below 1 N and for 0.2 s; a window is free when 80 % of it is), the oscillation amplitude ``max |e_osc|`` exceeds
   ``oscillation_amplitude`` (5 mm = x_b/10) in fewer than ``sustained_fraction`` (90 %) of the last half's
   windows (it persists through the last half: contact chatter while the task presses on an obstacle stops
   when the contact does; an unstable loop oscillates in free motion too), or the last half holds fewer than max(2 min_cycles, ``min_alternation_rate`` (1/s) x its length)
   alternations (so only oscillations of 0.5 Hz and faster count; slower motion is the operator's). A limit
   cycle that the postural optimisation keeps inside the limits (so test 3 sees no growth) is caught here. Why free
   motion only: in contact the environment drives the error (impacts, stick-slip, a piece jamming), and a
   contact-rich task then fills every window with forced "oscillation" whatever the controller; an unstable loop
   oscillates on its own, in free motion too. Contact is still judged by tests 1-3 (growth, bound, limits).
   Without force data every window counts; with force data and fewer than 3 free-motion windows in the last half,
   test 4 is not assessed (``sustained_assessed`` false in the verdict) and the verdict rests on tests 1-3.

Signals are averaged over and resampled onto a uniform grid (``resample_period`` 10 ms, or the median sample period
if longer; linear interpolation) before filtering, so a 10 Hz controller's state and a 1 kHz one are judged alike,
and the 250 Hz staircase of x_d is not differentiated into a fictitious velocity. The total energy of FicState
(spring plus kinetic) and the joint speeds are reported for the record (E3 "bounded energy") but decide nothing:
a push into an obstacle legitimately raises the stored energy.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray


class StabilityInputError(ValueError):
    """The time series cannot be judged (wrong shapes, NaN, too short, not increasing in time)."""


@dataclass(frozen=True)
class StabilityCriterion:
    """The thresholds of the test (module docstring); SI units."""

    error_bound: float = 0.20            # [m] 4 x_b
    detrend_window: float = 0.5          # [s] moving average removed from the error
    resample_period: float = 0.01        # [s] uniform grid of the analysis (raw samples averaged over it)
    oscillation_window: float = 1.0      # [s] window of the amplitude and energy peaks
    oscillation_amplitude: float = 0.005  # [m] x_b / 10
    sustained_fraction: float = 0.9      # of the last half's windows above the amplitude
    growth_ratio: float = 2.0            # fourth-quarter / third-quarter median window energy
    min_cycles: int = 3                  # oscillation cycles that make a growth or a sustained oscillation
    min_alternation_rate: float = 1.0    # [1/s] sign alternations a second of a sustained oscillation
    free_force: float = 1.0              # [N] free motion: |F| below this ...
    free_hold: float = 0.2               # [s] ... for this long
    free_window_share: float = 0.8       # a window is a free-motion window when this share of it is free
    stiffness: float = 200.0             # [N/m] K0 of the replica
    mass: float = 4.0                    # [kg] nominal TCP mass
    energy_floor: float | None = None    # [J] default 1/2 K0 oscillation_amplitude^2

    def floor(self) -> float:
        if self.energy_floor is not None:
            return self.energy_floor
        return 0.5 * self.stiffness * self.oscillation_amplitude ** 2

    def as_dict(self) -> dict:
        values = asdict(self)
        values["energy_floor"] = self.floor()
        return values


@dataclass
class StabilityVerdict:
    """Outcome and every measured number behind it (JSON-ready through ``as_dict``)."""

    stable: bool
    reasons: list[str]                    # why not stable (empty when stable)
    last_half_start: float                # [s] from the first sample
    duration: float                       # [s]
    violations_last_half: int
    max_error_last_half: float            # [m]
    max_error: float                      # [m] over the whole run
    energy_q3_median: float               # [J] median window peak of E_osc, third quarter (free-motion windows
                                          #     when each quarter has 2, see growth_in_free_motion)
    energy_q4_median: float               # [J] same, fourth quarter
    energy_growth: float                  # q4 / q3 (inf when q3 is 0 and q4 is not)
    oscillating_fraction: float           # share of the last half's windows with amplitude above the threshold
    alternations_q4: int                  # sign alternations of e_osc beyond +-h in the fourth quarter
    alternations_last_half: int           # same over the last half (in the windows test 4 judged)
    max_oscillation_amplitude: float      # [m] over the last half
    free_windows_last_half: int = -1      # windows of the last half in free motion (-1: no force data)
    windows_last_half: int = 0
    sustained_assessed: bool = True       # test 4 had at least 3 (free-motion) windows to judge
    growth_in_free_motion: bool = False   # test 3 compared free-motion windows only
    total_energy_peak_last_half: float | None = None   # [J] FicState total_energy (record only)
    total_energy_peak_first_half: float | None = None  # [J]
    joint_speed_peak_last_half: float | None = None    # [rad/s] (record only)
    criterion: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        values = asdict(self)
        for key, value in values.items():
            if isinstance(value, float) and not np.isfinite(value):
                values[key] = None if np.isnan(value) else ("inf" if value > 0 else "-inf")
        return values


def _series(name: str, time: NDArray, values: ArrayLike, columns: int | None) -> NDArray[np.float64]:
    array = np.asarray(values, dtype=np.float64)
    if columns is None:
        if array.shape != time.shape:
            raise StabilityInputError(f"{name} must have shape {time.shape}, got {array.shape}")
    else:
        if array.ndim == 1 and columns == 1:
            array = array[:, None]
        if array.ndim != 2 or array.shape[0] != time.shape[0]:
            raise StabilityInputError(f"{name} must have shape ({time.shape[0]}, k), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise StabilityInputError(f"{name} holds NaN or Inf")
    return array


def _time(name: str, values: ArrayLike) -> NDArray[np.float64]:
    time = np.asarray(values, dtype=np.float64)
    if time.ndim != 1 or time.size < 4:
        raise StabilityInputError(f"{name} must be a 1-D array of at least 4 samples, got shape {time.shape}")
    if not np.all(np.isfinite(time)) or np.any(np.diff(time) <= 0.0):
        raise StabilityInputError(f"{name} must be finite and strictly increasing")
    return time


def _moving_average(values: NDArray, samples: int) -> NDArray:
    """Centred moving average over ``samples`` (odd) rows, the edges padded with the end values."""
    if samples <= 1:
        return values.copy()
    half = samples // 2
    padded = np.pad(values, ((half, half), (0, 0)), mode="edge")
    cumulative = np.cumsum(np.vstack([np.zeros((1, values.shape[1])), padded]), axis=0)
    return (cumulative[samples:] - cumulative[:-samples]) / samples


def oscillation_components(time: ArrayLike, error: ArrayLike, criterion: StabilityCriterion = StabilityCriterion()
                           ) -> tuple[NDArray, NDArray, NDArray]:
    """(uniform time grid, e_osc on it (n, k), E_osc on it (n,)): the oscillatory part of the error and its energy."""
    time = _time("time", time)
    error = _series("error", time, error, columns=error.shape[1] if np.ndim(error) == 2 else 1)
    raw_step = float(np.median(np.diff(time)))
    step = max(raw_step, criterion.resample_period)
    grid = np.arange(time[0], time[-1] + 0.5 * step, step)
    grid = grid[grid <= time[-1]]
    # Average the raw samples over one grid period first: x_d arrives in steps (teleoperation and planner at
    # 250 Hz), and a staircase differentiated at 1 kHz would read as kinetic energy that no mass carries.
    smoothing = int(round(step / raw_step)) | 1
    smoothed = _moving_average(error, smoothing) if smoothing > 1 else error
    resampled = np.column_stack([np.interp(grid, time, smoothed[:, k]) for k in range(error.shape[1])])
    samples = max(1, int(round(criterion.detrend_window / step)) | 1)
    oscillation = resampled - _moving_average(resampled, samples)
    rate = np.gradient(oscillation, step, axis=0) if grid.size > 1 else np.zeros_like(oscillation)
    energy = 0.5 * criterion.stiffness * np.sum(oscillation ** 2, axis=1) + 0.5 * criterion.mass * np.sum(rate ** 2, axis=1)
    return grid, oscillation, energy


def _window_peaks(grid: NDArray, values: NDArray, start: float, stop: float, window: float) -> NDArray:
    """Peak of ``values`` in each window of length ``window`` tiling [start, stop] (a short last window merged)."""
    count = max(1, int(np.floor((stop - start) / window + 1e-9)))
    edges = np.linspace(start, stop, count + 1)
    peaks = []
    for low, high in zip(edges[:-1], edges[1:]):
        inside = (grid >= low) & (grid <= high)
        peaks.append(float(np.max(values[inside])) if np.any(inside) else 0.0)
    return np.asarray(peaks)


def _alternations(grid: NDArray, oscillation: NDArray, start: float, stop: float, level: float) -> int:
    """Most sign alternations, over the axes, between beyond +level and beyond -level (hysteresis) in [start, stop]."""
    inside = (grid >= start) & (grid <= stop)
    most = 0
    for axis in range(oscillation.shape[1]):
        values = oscillation[inside, axis]
        signs = np.sign(values[np.abs(values) > level])
        most = max(most, int(np.count_nonzero(np.diff(signs))))
    return most


def _free_motion(time: NDArray, magnitude: NDArray, criterion: StabilityCriterion) -> NDArray:
    """A sample is free motion (docs/EXPERIMENTS.md) when the force has been below free_force for at least free_hold."""
    below = magnitude < criterion.free_force
    free = np.zeros(time.size, dtype=bool)
    since = None
    for k in range(time.size):
        if below[k]:
            since = time[k] if since is None else since
            free[k] = time[k] - since >= criterion.free_hold
        else:
            since = None
    return free


def _counter_increase(time: NDArray, counter: NDArray, start: float) -> int:
    """Increase of a cumulative counter from the last sample at or before ``start`` to the last sample."""
    before = np.nonzero(time <= start)[0]
    base = counter[before[-1]] if before.size else 0.0
    return int(round(float(counter[-1] - base)))


def assess_stability(time: ArrayLike, error: ArrayLike, *, violation_time: ArrayLike | None = None,
                     violation_count: ArrayLike | None = None, total_energy: ArrayLike | None = None,
                     joint_velocity: ArrayLike | None = None, force_time: ArrayLike | None = None,
                     force: ArrayLike | None = None,
                     criterion: StabilityCriterion = StabilityCriterion()) -> StabilityVerdict:
    """Judge one run by the criterion of this module's docstring.

    time: (n,) [s]; error: (n, 3) translation error x_d - x_R [m] (or (n,) for one axis); violation_time and
    violation_count: samples of the cumulative violation-tick counter (LimitStatus.violation_ticks), may be
    sampled at another rate than the error; total_energy (n,) [J] and joint_velocity (n, 7) [rad/s] on ``time``,
    optional, reported only; force_time (m,) and force (m, 3) [N]: the wrist F/T force, which tells free motion
    from contact for test 4 (without it every window counts).
    """
    time = _time("time", time)
    error_array = np.asarray(error, dtype=np.float64)
    error_array = _series("error", time, error_array, columns=error_array.shape[1] if error_array.ndim == 2 else 1)
    start, end = float(time[0]), float(time[-1])
    duration = end - start
    half = start + 0.5 * duration
    third_quarter = start + 0.5 * duration
    fourth_quarter = start + 0.75 * duration
    # At least four windows a quarter, so that a median means something in a short run.
    window = max(min(criterion.oscillation_window, duration / 16.0), 1e-3)

    reasons: list[str] = []

    violations = 0
    if violation_count is not None:
        if violation_time is None:
            raise StabilityInputError("violation_count needs violation_time")
        v_time = _time("violation_time", violation_time)
        v_count = _series("violation_count", v_time, violation_count, columns=None)
        violations = _counter_increase(v_time, v_count, half)
        if violations > 0:
            reasons.append(f"{violations} limit-violation ticks in the last half")

    magnitude = np.linalg.norm(error_array, axis=1)
    last = time >= half
    max_error_last = float(np.max(magnitude[last]))
    if max_error_last > criterion.error_bound:
        reasons.append(f"tracking error {max_error_last:.3f} m above the bound {criterion.error_bound:.3f} m")

    grid, oscillation, energy = oscillation_components(time, error_array, criterion)
    amplitude = np.linalg.norm(oscillation, axis=1)
    level = 0.5 * criterion.oscillation_amplitude

    free_on_grid = None
    if force is not None and force_time is not None:
        f_time = _time("force_time", force_time)
        f_values = _series("force", f_time, force, columns=np.shape(force)[-1] if np.ndim(force) == 2 else 1)
        free = _free_motion(f_time, np.linalg.norm(f_values, axis=1), criterion)
        free_on_grid = np.interp(grid, f_time, free.astype(float)) > 0.5

    def edges_of(start_: float, stop_: float) -> NDArray:
        return np.linspace(start_, stop_, max(1, int(np.floor((stop_ - start_) / window + 1e-9))) + 1)

    def free_windows_of(edges: NDArray) -> NDArray:
        if free_on_grid is None:
            return np.ones(edges.size - 1, dtype=bool)
        shares = [np.mean(free_on_grid[(grid >= low) & (grid <= high)]) if np.any((grid >= low) & (grid <= high))
                  else 0.0 for low, high in zip(edges[:-1], edges[1:])]
        return np.asarray(shares) >= criterion.free_window_share

    def alternations_in(edges: NDArray, keep: NDArray) -> int:
        if np.all(keep):
            return _alternations(grid, oscillation, edges[0], edges[-1], level)
        return sum(_alternations(grid, oscillation, low, high, level)
                   for low, high, chosen_ in zip(edges[:-1], edges[1:], keep) if chosen_)

    # Test 3 on the free-motion windows of each quarter when both have at least 2, else on all of them.
    q3_edges, q4_edges = edges_of(third_quarter, fourth_quarter), edges_of(fourth_quarter, end)
    q3 = _window_peaks(grid, energy, third_quarter, fourth_quarter, window)
    q4 = _window_peaks(grid, energy, fourth_quarter, end, window)
    q3_free, q4_free = free_windows_of(q3_edges), free_windows_of(q4_edges)
    growth_free = free_on_grid is not None and q3_free.sum() >= 2 and q4_free.sum() >= 2
    if growth_free:
        q3, q4 = q3[q3_free], q4[q4_free]
    q3_median, q4_median = float(np.median(q3)), float(np.median(q4))
    growth = q4_median / q3_median if q3_median > 0.0 else (np.inf if q4_median > 0.0 else 1.0)
    alternations_q4 = alternations_in(q4_edges, q4_free if growth_free else np.ones(q4_edges.size - 1, bool))
    alternations_half = _alternations(grid, oscillation, half, end, level)
    if (q4_median > criterion.floor() and q4_median > criterion.growth_ratio * q3_median
            and alternations_q4 >= 2 * criterion.min_cycles):
        reasons.append(f"oscillation energy growing{' in free motion' if growth_free else ''}: last-quarter median "
                       f"window peak {q4_median * 1e3:.2f} mJ is {growth:.1f}x the third quarter's (limit "
                       f"{criterion.growth_ratio:.1f}x), {alternations_q4} alternations")

    amplitudes = _window_peaks(grid, amplitude, half, end, window)
    edges = np.linspace(half, end, amplitudes.size + 1)
    chosen = free_windows_of(edges)
    free_windows = -1 if free_on_grid is None else int(np.sum(chosen))
    assessed = int(np.sum(chosen)) >= 3
    fraction = float(np.mean(amplitudes[chosen] > criterion.oscillation_amplitude)) if np.any(chosen) else 0.0
    judged = (end - half) * float(np.mean(chosen))
    alternations_judged = alternations_in(edges, chosen)
    needed = max(2 * criterion.min_cycles, int(np.ceil(criterion.min_alternation_rate * judged)))
    if assessed and fraction >= criterion.sustained_fraction and alternations_judged >= needed:
        where = "free-motion " if not np.all(chosen) else ""
        reasons.append(f"sustained oscillation: amplitude above {criterion.oscillation_amplitude * 1e3:.1f} mm in "
                       f"{fraction:.0%} of the last half's {int(np.sum(chosen))} {where}{window:.2f} s windows, "
                       f"{alternations_judged} alternations")

    total_last = total_first = None
    if total_energy is not None:
        total = _series("total_energy", time, total_energy, columns=None)
        total_last = float(np.max(total[last]))
        total_first = float(np.max(total[~last])) if np.any(~last) else None
    speed_last = None
    if joint_velocity is not None:
        velocity = _series("joint_velocity", time, joint_velocity, columns=np.shape(joint_velocity)[-1])
        speed_last = float(np.max(np.abs(velocity[last])))

    return StabilityVerdict(
        stable=not reasons, reasons=reasons, last_half_start=half - start, duration=duration,
        violations_last_half=violations, max_error_last_half=max_error_last, max_error=float(np.max(magnitude)),
        energy_q3_median=q3_median, energy_q4_median=q4_median, energy_growth=float(growth),
        oscillating_fraction=fraction, alternations_q4=alternations_q4, alternations_last_half=alternations_judged,
        free_windows_last_half=free_windows, windows_last_half=int(amplitudes.size), sustained_assessed=assessed,
        growth_in_free_motion=bool(growth_free),
        max_oscillation_amplitude=float(np.max(amplitude[grid >= half])),
        total_energy_peak_last_half=total_last, total_energy_peak_first_half=total_first,
        joint_speed_peak_last_half=speed_last, criterion=criterion.as_dict())
