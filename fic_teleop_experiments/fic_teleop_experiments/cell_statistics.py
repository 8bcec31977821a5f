"""Per-cell statistics over seeds, and the comparison of two laws on the same cell (docs/EXPERIMENTS.md, "Claims").

One cell's share of runs that pass a verdict is a binomial proportion k/n; its 95 % interval is Wilson's score
interval. Wilson (1927), "Probable inference, the law of succession, and statistical inference", JASA 22: for k
successes in n trials and z the normal quantile (1.959964 for 95 %),

    centre = (k + z^2/2) / (n + z^2),   half width = z sqrt(k (n - k) / n + z^2/4) / (n + z^2)

which, unlike the normal approximation, stays inside [0, 1] and is not degenerate at k = 0 or k = n -- the cells
of a stability map are mostly there.

Two laws on the same cell are two independent proportions (each run has its own seed; the laws do not share a
run). Their difference p1 - p2 gets Newcombe's hybrid score interval (Newcombe 1998, "Interval estimation for the
difference between independent proportions: comparison of eleven methods", Stat. Med. 17:873-890, method 10):
with (l_i, u_i) each proportion's Wilson interval,

    low  = (p1 - p2) - sqrt((p1 - l1)^2 + (u2 - p2)^2)
    high = (p1 - p2) + sqrt((u1 - p1)^2 + (p2 - l2)^2)

It keeps close to its nominal 95 % at n = 20 and, like Wilson's, is not degenerate at 0/n or n/n, where the Wald
interval of the difference collapses to a point.

The test of "the two laws are equally often stable" is Boschloo's exact test, two-sided (Boschloo 1970,
"Raised conditional level of significance for the 2 x 2-table when testing the equality of two probabilities",
Statistica Neerlandica 24:1-35; scipy.stats.boschloo_exact). Why that one: the design fixes the number of seeds of
each law (two independent binomial samples), not the margins of the 2 x 2 table that Fisher's exact test
conditions on; Fisher's test is then conservative (its size is well under 5 % at n = 20, so it misses differences it
could see). Boschloo's test uses Fisher's p as its statistic and maximises over the unknown common proportion
instead of conditioning: it is exact (never above its nominal size) and each one-sided p is at most Fisher's one-sided
p, so it never misses what Fisher's test finds on that side. scipy's two-sided p is twice the smaller one-sided p
(its documented definition). Fisher's two-sided p (by table probability) is kept beside it, since earlier results
quote it. The two-sided tests are not ordered by a theorem, but at 20 seeds against 20 Boschloo's p is at most
Fisher's on every one of the 231 possible tables (enumerated; test/experiments/test_cell_statistics.py does it at 10
against 10).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

Z_95 = 1.959963984540054


def _check_counts(successes: int, trials: int) -> None:
    if trials <= 0 or not 0 <= successes <= trials:
        raise ValueError(f"need 0 <= successes <= trials and trials > 0, got {successes}/{trials}")


def wilson_interval(successes: int, trials: int, z: float = Z_95) -> tuple[float, float]:
    """(low, high) of the Wilson score interval for ``successes`` of ``trials``; ValueError for impossible counts."""
    _check_counts(successes, trials)
    centre = (successes + z * z / 2.0) / (trials + z * z)
    half = z * math.sqrt(successes * (trials - successes) / trials + z * z / 4.0) / (trials + z * z)
    # The interval holds the estimate; rounding put its end an ulp inside it (k = n: 0.9999999999999999).
    share = successes / trials
    return max(0.0, min(share, centre - half)), min(1.0, max(share, centre + half))


def newcombe_difference_interval(successes_1: int, trials_1: int, successes_2: int, trials_2: int,
                                 z: float = Z_95) -> tuple[float, float, float]:
    """(p1 - p2, low, high): the difference of two independent proportions and Newcombe's hybrid score interval
    (method 10) built from each proportion's Wilson interval."""
    low_1, high_1 = wilson_interval(successes_1, trials_1, z)   # refuses impossible counts first
    low_2, high_2 = wilson_interval(successes_2, trials_2, z)
    p1, p2 = successes_1 / trials_1, successes_2 / trials_2
    difference = p1 - p2
    low = difference - math.sqrt((p1 - low_1) ** 2 + (high_2 - p2) ** 2)
    high = difference + math.sqrt((high_1 - p1) ** 2 + (p2 - low_2) ** 2)
    return difference, max(-1.0, low), min(1.0, high)


def _table(successes_1: int, trials_1: int, successes_2: int, trials_2: int) -> list[list[int]]:
    """The 2 x 2 table with one column per law (scipy's exact tests take each column as one binomial sample)."""
    _check_counts(successes_1, trials_1)
    _check_counts(successes_2, trials_2)
    return [[successes_1, successes_2], [trials_1 - successes_1, trials_2 - successes_2]]


def boschloo_p(successes_1: int, trials_1: int, successes_2: int, trials_2: int) -> float:
    """Two-sided p of Boschloo's exact test that both proportions are equal."""
    from scipy.stats import boschloo_exact

    return float(min(1.0, boschloo_exact(_table(successes_1, trials_1, successes_2, trials_2),
                                         alternative="two-sided").pvalue))


def fisher_p(successes_1: int, trials_1: int, successes_2: int, trials_2: int) -> float:
    """Two-sided p of Fisher's exact test (kept beside Boschloo's for comparison with earlier results)."""
    from scipy.stats import fisher_exact

    return float(fisher_exact(_table(successes_1, trials_1, successes_2, trials_2), alternative="two-sided")[1])


@dataclass
class Proportion:
    """k of n runs passing a verdict, with its 95 % Wilson interval (None when no run was judged)."""
    k: int
    n: int
    interval_95: tuple[float, float] | None

    def as_dict(self) -> dict:
        return asdict(self)


def proportion(verdicts: Sequence[bool | None]) -> Proportion:
    """The passing share of the judged runs (None: the run was not judged, e.g. too short)."""
    judged = [value for value in verdicts if value is not None]
    k = sum(1 for value in judged if value)
    return Proportion(k=k, n=len(judged), interval_95=wilson_interval(k, len(judged)) if judged else None)


@dataclass
class LawComparison:
    """One law against another on the same cell: p_law - p_other with Newcombe's 95 % interval and the exact tests.
    All None when either law has no judged run."""
    law: Proportion
    other: Proportion
    difference: float | None
    difference_interval_95: tuple[float, float] | None
    boschloo_p: float | None
    fisher_p: float | None

    def as_dict(self) -> dict:
        return asdict(self)


def compare_laws(law: Proportion, other: Proportion) -> LawComparison:
    if law.n == 0 or other.n == 0:
        return LawComparison(law, other, None, None, None, None)
    difference, low, high = newcombe_difference_interval(law.k, law.n, other.k, other.n)
    return LawComparison(law, other, difference, (low, high), boschloo_p(law.k, law.n, other.k, other.n),
                         fisher_p(law.k, law.n, other.k, other.n))


def median_and_p95(values: Sequence[float]) -> tuple[float | None, float | None]:
    """Median and 95th percentile (linear interpolation between order statistics, numpy's default); None, None for
    no values."""
    finite = [float(v) for v in values if v is not None and math.isfinite(v)]
    if not finite:
        return None, None
    return float(np.median(finite)), float(np.percentile(finite, 95))


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
    share = proportion(stable)
    return CellStatistics(
        runs=len(stable), assessed=share.n, stable=share.k, stable_interval_95=share.interval_95,
        error_median_m=float(np.median(error_rms)), error_p95_m=float(np.percentile(error_max, 95)),
        peak_force_median_n=float(np.median(peak_force)), peak_force_p95_n=float(np.percentile(peak_force, 95)))
