"""Per-cell statistics over seeds: the stable count k/n with its 95 % Wilson score interval, and the median and
95th percentile of the tracking error and of the peak force (docs/RESULTS.md, "Seeds and statistics").

Wilson (1927), "Probable inference, the law of succession, and statistical inference", JASA 22: for k successes
in n trials and z the normal quantile (1.959964 for 95 %),

    centre = (k + z^2/2) / (n + z^2),   half width = z sqrt(k (n - k) / n + z^2/4) / (n + z^2)

which, unlike the normal approximation, stays inside [0, 1] and is not degenerate at k = 0 or k = n -- the
cells of a stability map are mostly there.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

Z_95 = 1.959963984540054


def wilson_interval(successes: int, trials: int, z: float = Z_95) -> tuple[float, float]:
    """(low, high) of the Wilson score interval for ``successes`` of ``trials``; ValueError for impossible counts."""
    if trials <= 0 or not 0 <= successes <= trials:
        raise ValueError(f"need 0 <= successes <= trials and trials > 0, got {successes}/{trials}")
    centre = (successes + z * z / 2.0) / (trials + z * z)
    half = z * math.sqrt(successes * (trials - successes) / trials + z * z / 4.0) / (trials + z * z)
    return max(0.0, centre - half), min(1.0, centre + half)


@dataclass
class CellStatistics:
    runs: int
    assessed: int                  # runs long enough for the verdict
    stable: int                    # k of the assessed runs
    stable_interval_95: tuple[float, float] | None   # Wilson, on the assessed runs
    error_median_m: float          # over the runs' RMS tracking errors
    error_p95_m: float             # 95th percentile of the runs' maximum tracking errors
    peak_force_median_n: float
    peak_force_p95_n: float

    def as_dict(self) -> dict:
        return asdict(self)


def cell_statistics(stable: Sequence[bool | None], error_rms: Sequence[float], error_max: Sequence[float],
                    peak_force: Sequence[float]) -> CellStatistics:
    """``stable`` per run (None: not assessed), and each run's RMS and maximum error [m] and peak force [N]."""
    assessed = [value for value in stable if value is not None]
    k = sum(1 for value in assessed if value)
    return CellStatistics(
        runs=len(stable), assessed=len(assessed), stable=k,
        stable_interval_95=wilson_interval(k, len(assessed)) if assessed else None,
        error_median_m=float(np.median(error_rms)), error_p95_m=float(np.percentile(error_max, 95)),
        peak_force_median_n=float(np.median(peak_force)), peak_force_p95_n=float(np.percentile(peak_force, 95)))
