"""Wilson intervals against values worked by hand from Wilson's formula and against scipy's."""
from __future__ import annotations

import pytest

from sim_bridge.experiments.cell_statistics import cell_statistics, wilson_interval


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


def test_impossible_counts_are_refused():
    with pytest.raises(ValueError):
        wilson_interval(3, 2)
    with pytest.raises(ValueError):
        wilson_interval(0, 0)


def test_cell_statistics_counts_only_assessed_runs():
    stats = cell_statistics([True, None, False, True], [0.01, 0.02, 0.03, 0.04], [0.1, 0.2, 0.3, 0.4], [1, 2, 3, 4])
    assert (stats.runs, stats.assessed, stats.stable) == (4, 3, 2)
    assert stats.stable_interval_95 == pytest.approx(wilson_interval(2, 3))
    assert stats.error_median_m == pytest.approx(0.025)
    assert stats.peak_force_p95_n == pytest.approx(3.85)
