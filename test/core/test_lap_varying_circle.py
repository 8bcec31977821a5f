"""LapVaryingCircle (fic_core/trajectories.py): the paper's circle with a period and a diameter of its own per lap."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_core.errors import FicInputError
from fic_core.trajectories import Circle, LapVaryingCircle

CENTRE = np.array([0.45, 0.0, 0.35])


def test_each_lap_starts_at_its_own_speed_and_diameter_and_blends_to_the_next() -> None:
    source = LapVaryingCircle(CENTRE, [4.0, 6.0], [0.20, 0.17, 0.23], phase=0.3)
    times = np.arange(-1.0, 14.0, 1e-3)
    angles = np.array([source.angle(t) for t in times])
    speeds = np.gradient(angles, times)
    for t, speed in ((-0.5, 2 * math.pi / 4), (0.0, 2 * math.pi / 4), (4.0, 2 * math.pi / 6), (12.0, 2 * math.pi / 6)):
        assert speeds[int(round((t + 1.0) / 1e-3))] == pytest.approx(speed, rel=1e-4)
    # a lap turns by its duration times the mean of its end speeds; the angle and its speed have no step
    assert source.angle(4.0) - source.angle(0.0) == pytest.approx(4.0 * 0.5 * (2 * math.pi / 4 + 2 * math.pi / 6))
    assert source.angle(10.0) - source.angle(4.0) == pytest.approx(2 * math.pi)
    assert np.abs(np.diff(speeds)).max() < 1e-3
    assert source.angle(0.0) == pytest.approx(0.3)
    for t, radius in ((0.0, 0.10), (4.0, 0.085), (10.0, 0.115), (2.0, 0.5 * (0.10 + 0.085)), (13.0, 0.115)):
        assert np.linalg.norm(source.point(t) - CENTRE) == pytest.approx(radius)
    point = source.point(7.0)
    assert math.atan2(point[1], point[0] - CENTRE[0]) == pytest.approx(math.remainder(source.angle(7.0), 2 * math.pi))


def test_the_path_is_continuous_and_its_speed_bounded_across_lap_ends() -> None:
    source = LapVaryingCircle(CENTRE, [4.0, 6.0, 5.0], [0.20, 0.17, 0.23, 0.2])
    times = np.arange(0.0, 15.0, 1e-3)
    points = np.array([source.point(t) for t in times])
    speeds = np.linalg.norm(np.diff(points, axis=0), axis=1) / 1e-3
    # the fastest lap's tangential speed plus the radial speed of the quintic blend (15/8 * dr / T)
    assert speeds.max() < 2 * math.pi * 0.115 / 4.0 + 15 / 8 * 0.03 / 6.0 * 2 + 1e-3
    assert np.abs(np.diff(speeds)).max() < 1e-3
    np.testing.assert_allclose(points[:, 2], CENTRE[2])


def test_constant_laps_are_the_paper_circle() -> None:
    varying = LapVaryingCircle(CENTRE, [5.0, 5.0], [0.2, 0.2, 0.2], phase=0.7)
    circle = Circle(CENTRE, 0.2, 5.0, phase=0.7)
    for t in np.linspace(0.0, 12.0, 37):
        np.testing.assert_allclose(varying.point(t), circle.point(t), atol=1e-12)


def test_a_seed_draws_laps_within_the_ranges_that_cover_the_duration_and_never_repeat() -> None:
    a = LapVaryingCircle.randomised(CENTRE, np.random.default_rng(4), 30.0, (4.0, 6.0), (0.17, 0.23))
    b = LapVaryingCircle.randomised(CENTRE, np.random.default_rng(4), 30.0, (4.0, 6.0), (0.17, 0.23))
    c = LapVaryingCircle.randomised(CENTRE, np.random.default_rng(5), 30.0, (4.0, 6.0), (0.17, 0.23))
    np.testing.assert_array_equal(a.periods, b.periods)
    assert a.phase == b.phase and a.phase != c.phase
    assert a.periods.sum() >= 30.0 > a.periods[:-1].sum()
    assert np.all((a.periods >= 4.0) & (a.periods <= 6.0))
    assert np.all((a.diameters >= 0.17) & (a.diameters <= 0.23))
    assert len(set(np.round(a.periods, 6))) == a.periods.size
    arcs = ((-0.7, 0.7), (2.4, 3.8))
    phases = [LapVaryingCircle.randomised(CENTRE, np.random.default_rng(s), 10.0, phase_ranges=arcs).phase
              for s in range(40)]
    assert all(-0.7 <= p <= 0.7 or 2.4 <= p <= 3.8 for p in phases)
    assert 10 < sum(p > 2.0 for p in phases) < 30                  # both arcs drawn


@pytest.mark.parametrize("periods, diameters", [([], [0.2]), ([5.0], [0.2]), ([5.0, -1.0], [0.2, 0.2, 0.2]),
                                                ([5.0], [0.2, 0.0]), ([5.0], [0.2, math.nan])])
def test_bad_laps_are_refused_in_one_line(periods, diameters) -> None:
    with pytest.raises(FicInputError):
        LapVaryingCircle(CENTRE, periods, diameters)


def test_bad_ranges_are_refused() -> None:
    for bad in (dict(period_range=(0.0, 5.0)), dict(diameter_range=(0.3, 0.2)), dict(phase_ranges=()),
                dict(phase_ranges=((1.0, math.nan),))):
        with pytest.raises(FicInputError):
            LapVaryingCircle.randomised(CENTRE, np.random.default_rng(1), 10.0, **bad)


def test_a_lap_shorter_than_a_second_is_a_lap() -> None:
    """Periods are any positive seconds: laps of 0.5 s and 0.25 s turn the circle once each in that time (a lap's
    turn is its duration times the mean of its end speeds: 0.5 (2 pi / 0.5 + 2 pi / 0.25) / 2 for the first)."""
    source = LapVaryingCircle(CENTRE, [0.5, 0.25], [0.2, 0.2, 0.2])
    assert source.angle(0.5) - source.angle(0.0) == pytest.approx(0.25 * (2 * math.pi / 0.5 + 2 * math.pi / 0.25))
    assert source.angle(0.75) - source.angle(0.5) == pytest.approx(2 * math.pi)
    with pytest.raises(FicInputError, match="positive seconds"):
        LapVaryingCircle(CENTRE, [0.5, 0.0], [0.2, 0.2, 0.2])


def test_point_ranges_give_that_value() -> None:
    """A range may be one value (low == high): laps of exactly 5 s, 0.2 m, starting at exactly 0.5 rad."""
    source = LapVaryingCircle.randomised(CENTRE, np.random.default_rng(2), 12.0, (5.0, 5.0), (0.2, 0.2),
                                         phase_ranges=((0.5, 0.5),))
    np.testing.assert_array_equal(source.periods, [5.0, 5.0, 5.0])
    np.testing.assert_array_equal(source.diameters, 0.2)
    assert source.phase == 0.5
