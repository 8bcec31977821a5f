"""The task's own periodic motion, removed from a residual: what is left differs from lap to lap (docs/EXPERIMENTS.md,
"The stability criterion").

The caller removes the commanded motion from x_M, x_d and x_R (the operator's target, the planner, the target one
delay later), but a delayed loop driven by a periodic task does not follow its command exactly: the hand gives way
to the force it feels, the replica lags the delayed command. For a loop that is stable that forced response is
itself periodic at the task's period P once the start-up has passed (a stable linear loop's steady response to a
P-periodic input is P-periodic; E1's lap repeats every 5 s), so it repeats at the lap and an autocorrelation test
reads it as a sustained oscillation at P. What the loop creates on its own -- a limit cycle at the loop's own
period, an oscillation that grows -- does not repeat from lap to lap and survives the removal.

The lap's typical motion is estimated over the span given, phase by phase: the residual's MEDIAN over the laps at
the same phase of the lap (t - start mod P, in bins of the median sample period). A median, not a mean: when one lap
differs (the closed-loop operator sweeping the pushable obstacle on it, a script's last move missing at the run's
end), a mean would hand a share of that lap to every other lap, the same share on each, which then repeats at P and
reads as periodic; the median leaves the odd lap alone in the residual, where it does not repeat. Subtracting it
leaves the part that differs between laps. Its blind spot, stated: a steady oscillation whose frequency lies near a
multiple of 1/P is in part (wholly when locked to it) taken for the task's motion; a growing one is not (its laps
differ), and the energy tests judge growth whatever its period.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def without_lap_median(time: NDArray[np.float64], values: NDArray[np.float64], period: float, start: float
                       ) -> NDArray[np.float64]:
    """``values`` (n, k) on ``time`` (n,) minus their median at the same phase of a ``period`` [s] lap, the median
    taken over the samples at or after ``start`` [s]; rows before ``start`` are returned unchanged (not judged)."""
    if period <= 0.0:
        raise ValueError(f"the task period must be positive, got {period}")
    step = float(np.median(np.diff(time)))
    bins = max(1, int(round(period / step)))
    inside = np.nonzero(time >= start)[0]
    # Rounded, not floored: samples on a uniform grid fall on bin centres, and a floor would send a sample at
    # 4.9999999 s of the lap to another bin than its neighbour laps' 5.0000001 s.
    position = np.rint((time[inside] - start) / step).astype(int)
    lap, phase = position // bins, position % bins
    table = np.full((int(lap.max()) + 1, bins, values.shape[1]), np.nan)
    table[lap, phase] = values[inside]
    typical = np.nanmedian(table, axis=0)        # every bin holds the first lap's sample at least
    out = values.copy()
    out[inside] = values[inside] - typical[phase]
    return out
