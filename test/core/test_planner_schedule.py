"""The planner on its own clock (fic_core.planner_schedule): a late tick integrates as the nominal ticks would, a
clock going back moves nothing, and the trajectory's time never runs before its origin."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.planner import HarmonicPlanner
from fic_core.planner_schedule import PlannerSchedule
from fic_core.trajectories import Circle, FixedPoint

PERIOD = 0.004


def schedule(origin: float = 0.0) -> PlannerSchedule:
    planner = HarmonicPlanner(8.0, 0.25)
    circle = Circle([0.45, 0.0, 0.35], 0.2, 5.0, normal=[0.0, 0.0, 1.0], phase=0.0)
    planner.reset(circle.point(0.0))
    return PlannerSchedule(planner, circle, origin, PERIOD)


@settings(max_examples=20, deadline=None, derandomize=True)
@given(late_periods=st.integers(1, 40), start=st.floats(0.0, 3.0))
def test_one_late_tick_moves_the_planner_as_the_nominal_ticks_do(late_periods: int, start: float) -> None:
    late, nominal = schedule(), schedule()
    for s in (late, nominal):
        for k in range(50):  # the same history up to ``start``
            s.advance(start * k / 49)
    for k in range(1, late_periods + 1):
        nominal.advance(start + k * PERIOD)
    late.advance(start + late_periods * PERIOD)
    np.testing.assert_allclose(late.planner.position, nominal.planner.position, atol=1e-9)
    np.testing.assert_allclose(late.planner.velocity, nominal.planner.velocity, atol=1e-9)


def test_a_clock_going_back_or_standing_moves_nothing() -> None:
    s = schedule()
    s.advance(0.0)
    position = s.advance(0.5).copy()
    np.testing.assert_array_equal(s.advance(0.5), position)
    np.testing.assert_array_equal(s.advance(0.2), position)
    assert not np.array_equal(s.advance(0.6), position)  # and on from 0.5, not from 0.2


def test_the_trajectory_waits_for_its_origin_and_a_retune_starts_at_rest() -> None:
    s = schedule(origin=10.0)
    start = s.planner.position.copy()
    s.advance(0.0)
    np.testing.assert_allclose(s.advance(5.0), start, atol=1e-12)  # x_t(0) all along: the planner stays
    s.restart_trajectory(FixedPoint([0.45, 0.1, 0.35]), origin=5.0)
    s.advance(5.5)
    assert s.target == pytest.approx([0.45, 0.1, 0.35])
    moved = s.planner.position.copy()
    s.retune(HarmonicPlanner(4.0, 0.1))
    np.testing.assert_array_equal(s.planner.position, moved)
    np.testing.assert_array_equal(s.planner.velocity, np.zeros(3))
    with pytest.raises(ValueError, match="nominal_period"):
        PlannerSchedule(HarmonicPlanner(8.0, 0.25), FixedPoint([0.0, 0.0, 0.0]), 0.0, 0.0)
