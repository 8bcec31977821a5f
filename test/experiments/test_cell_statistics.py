"""The cell statistics against values worked by hand, published values and independent implementations."""
from __future__ import annotations

import math

import pytest

from fic_teleop_experiments.cell_statistics import (
    Proportion,
    boschloo_p,
    cell_statistics,
    compare_laws,
    fisher_p,
    median_and_p95,
    newcombe_difference_interval,
    proportion,
    wilson_interval,
)


@pytest.mark.parametrize("k, n, low, high", [
    (0, 5, 0.0, 0.4345),        # z^2/(n+z^2) = 3.8415/8.8415
    (5, 5, 0.5655, 1.0),
    (2, 5, 0.1176, 0.7693),
    (10, 20, 0.2993, 0.7007),
])
def test_wilson_interval_matches_the_formula(k, n, low, high):
    assert wilson_interval(k, n) == pytest.approx((low, high), abs=5e-4)


def test_wilson_interval_agrees_with_scipy():
    """scipy's binomial test reports the same Wilson interval (an independent implementation)."""
    from scipy.stats import binomtest
    for k, n in [(0, 5), (3, 7), (9, 10), (17, 40)]:
        interval = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
        assert wilson_interval(k, n) == pytest.approx((interval.low, interval.high), abs=1e-9)


def test_the_wilson_interval_holds_its_estimate_exactly_at_every_count():
    """Rounding once left the end of a k = n interval an ulp below k / n (0.9999999999999999 for 101 of 101), and
    the plot of the interval's error bars refused the negative length."""
    for n in range(1, 400):
        for k in range(n + 1):
            low, high = wilson_interval(k, n)
            assert 0.0 <= low <= k / n <= high <= 1.0, (k, n, low, high)
        assert wilson_interval(n, n)[1] == 1.0 and wilson_interval(0, n)[0] == 0.0


def test_impossible_counts_are_refused():
    for call in (lambda: wilson_interval(3, 2), lambda: wilson_interval(0, 0),
                 lambda: newcombe_difference_interval(1, 0, 0, 5), lambda: boschloo_p(6, 5, 0, 5),
                 lambda: fisher_p(0, 5, -1, 5)):
        with pytest.raises(ValueError):
            call()


@pytest.mark.parametrize("k1, n1, k2, n2, low, high", [
    (56, 70, 48, 80, 0.0524, 0.3339),     # Newcombe (1998), Table II, example (a)
    (9, 10, 3, 10, 0.1705, 0.8090),       # example (b)
    (0, 10, 0, 10, -0.2775, 0.2775),      # by hand: +-(Wilson upper bound of 0/10) = z^2/(10+z^2)
])
def test_newcombe_interval_matches_published_values(k1, n1, k2, n2, low, high):
    difference, lower, upper = newcombe_difference_interval(k1, n1, k2, n2)
    assert difference == pytest.approx(k1 / n1 - k2 / n2)
    assert (lower, upper) == pytest.approx((low, high), abs=1e-4)


def test_newcombe_interval_is_antisymmetric_and_stays_in_bounds():
    d, low, high = newcombe_difference_interval(20, 20, 15, 20)
    d_swapped, low_swapped, high_swapped = newcombe_difference_interval(15, 20, 20, 20)
    assert (d_swapped, low_swapped, high_swapped) == pytest.approx((-d, -high, -low))
    assert -1.0 <= low < d < high <= 1.0
    assert newcombe_difference_interval(20, 20, 0, 20)[2] == 1.0


def test_fisher_p_matches_the_hypergeometric_sum():
    # 5/5 against 0/5: only this table and its mirror are as extreme, each 1 / C(10, 5).
    assert fisher_p(5, 5, 0, 5) == pytest.approx(2 / math.comb(10, 5))
    # 20/20 against 15/20: P(no failure among the first law's 20 of 40 with 5 failures), doubled by symmetry.
    assert fisher_p(20, 20, 15, 20) == pytest.approx(2 * math.comb(20, 5) / math.comb(40, 5))


def _one_sided_fisher(x1: int, n1: int, x2: int, n2: int, side: str) -> float:
    from scipy.stats import fisher_exact
    return fisher_exact([[x1, x2], [n1 - x1, n2 - x2]], alternative=side)[1]


def _boschloo_by_enumeration(k1: int, n1: int, k2: int, n2: int, grid: int = 2001) -> float:
    """Boschloo's two-sided p from its definition, twice the smaller one-sided p: for each side, the tables whose
    one-sided Fisher p is at most the observed one, their probability under a common proportion pi, maximised over pi
    on a fine grid."""
    import numpy as np
    from scipy.stats import binom
    pi = np.linspace(0.0, 1.0, grid)
    pmf_1 = binom.pmf(np.arange(n1 + 1)[:, None], n1, pi)
    pmf_2 = binom.pmf(np.arange(n2 + 1)[:, None], n2, pi)
    sides = []
    for side in ("less", "greater"):
        observed = _one_sided_fisher(k1, n1, k2, n2, side)
        extreme = [(x1, x2) for x1 in range(n1 + 1) for x2 in range(n2 + 1)
                   if _one_sided_fisher(x1, n1, x2, n2, side) <= observed * (1 + 1e-9)]
        sides.append(float(np.max(sum(pmf_1[x1] * pmf_2[x2] for x1, x2 in extreme))))
    return min(1.0, 2.0 * min(sides))


@pytest.mark.parametrize("k1, n1, k2, n2", [(5, 5, 2, 5), (6, 6, 1, 6), (4, 6, 0, 5)])
def test_boschloo_p_matches_its_definition(k1, n1, k2, n2):
    assert boschloo_p(k1, n1, k2, n2) == pytest.approx(_boschloo_by_enumeration(k1, n1, k2, n2), rel=2e-3)


def test_boschloo_p_matches_scipys_documented_example_and_is_never_above_fishers_doubled_one_sided_p():
    from scipy.stats import boschloo_exact
    # scipy's documentation: the 'greater' test on [[74, 31], [43, 32]] gives p = 0.0355; the two-sided value
    # must be the same call with our column-per-law table.
    assert boschloo_exact([[74, 31], [43, 32]], alternative="greater").pvalue == pytest.approx(0.0355, abs=1e-4)
    assert boschloo_p(74, 117, 31, 63) == pytest.approx(
        boschloo_exact([[74, 31], [43, 32]], alternative="two-sided").pvalue)
    for k1, k2 in [(20, 15), (20, 10), (12, 8), (3, 0), (19, 20)]:
        doubled_fisher = min(1.0, 2 * min(_one_sided_fisher(k1, 20, k2, 20, side) for side in ("less", "greater")))
        assert boschloo_p(k1, 20, k2, 20) <= doubled_fisher + 1e-12
    assert boschloo_p(20, 20, 20, 20) == pytest.approx(1.0)


def test_boschloo_is_never_less_sensitive_than_fisher_at_ten_seeds_a_law():
    """Every table of 10 seeds against 10: the exact test chosen never gives a larger p than Fisher's."""
    for k1 in range(11):
        for k2 in range(k1 + 1):
            assert boschloo_p(k1, 10, k2, 10) <= fisher_p(k1, 10, k2, 10) + 1e-9, (k1, k2)


def test_proportion_counts_only_judged_runs():
    share = proportion([True, None, False, True, True])
    assert (share.k, share.n) == (3, 4)
    assert share.interval_95 == pytest.approx(wilson_interval(3, 4))
    assert proportion([None, None]) == Proportion(0, 0, None)


def test_compare_laws_carries_all_figures_and_none_without_runs():
    comparison = compare_laws(Proportion(20, 20, wilson_interval(20, 20)), Proportion(15, 20, wilson_interval(15, 20)))
    assert comparison.difference == pytest.approx(0.25)
    assert comparison.difference_interval_95 == pytest.approx(newcombe_difference_interval(20, 20, 15, 20)[1:])
    assert comparison.fisher_p == pytest.approx(fisher_p(20, 20, 15, 20))
    assert comparison.boschloo_p < comparison.fisher_p
    empty = compare_laws(Proportion(3, 4, wilson_interval(3, 4)), Proportion(0, 0, None))
    assert (empty.difference, empty.difference_interval_95, empty.boschloo_p) == (None, None, None)


def test_median_and_p95():
    assert median_and_p95(list(range(1, 21))) == pytest.approx((10.5, 19.05))
    assert median_and_p95([]) == (None, None)
    assert median_and_p95([None, float("nan"), 2.0]) == (2.0, 2.0)


def test_cell_statistics_counts_only_assessed_runs():
    stats = cell_statistics([True, None, False, True], [0.01, 0.02, 0.03, 0.04], [0.1, 0.2, 0.3, 0.4], [1, 2, 3, 4])
    assert (stats.runs, stats.assessed, stats.stable) == (4, 3, 2)
    assert stats.stable_interval_95 == pytest.approx(wilson_interval(2, 3))
    assert stats.error_median_m == pytest.approx(0.025)
    assert stats.peak_force_p95_n == pytest.approx(3.85)
