"""Trajectory sources: fixed point, via-points (by time or when reached), the paper's circle."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.errors import FicInputError
from fic_core.trajectories import Circle, FixedPoint, ViaPoints


def test_fixed_point() -> None:
    source = FixedPoint([0.5, 0.0, 0.4])
    np.testing.assert_array_equal(source.point(0.0), [0.5, 0.0, 0.4])
    np.testing.assert_array_equal(source.point(100.0, position=[0, 0, 0]), [0.5, 0.0, 0.4])


def test_paper_circle_geometry() -> None:
    centre = np.array([0.5, 0.0, 0.4])
    circle = Circle(centre)  # 0.20 m diameter, 5 s period, in the x-y plane
    times = np.linspace(0.0, 5.0, 501)
    points = np.array([circle.point(t) for t in times])
    np.testing.assert_allclose(np.linalg.norm(points - centre, axis=1), 0.10, rtol=1e-12)
    np.testing.assert_allclose(points[:, 2], 0.4)
    np.testing.assert_allclose(points[0], points[-1], atol=1e-12)  # period 5 s
    np.testing.assert_allclose(points[0], centre + [0.1, 0.0, 0.0])
    speeds = np.linalg.norm(np.diff(points, axis=0), axis=1) / np.diff(times)
    np.testing.assert_allclose(speeds, 2 * math.pi * 0.1 / 5.0, rtol=1e-3)
    assert circle.speed == pytest.approx(2 * math.pi * 0.1 / 5.0)


@pytest.mark.parametrize("normal", [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 1.0, 1.0), (0.0, 0.0, -1.0)])
def test_circle_lies_in_the_plane_normal_to_normal(normal) -> None:
    centre = np.array([0.4, 0.1, 0.3])
    circle = Circle(centre, diameter=0.3, period=2.0, normal=normal, phase=0.5)
    unit = np.array(normal) / np.linalg.norm(normal)
    for t in np.linspace(0.0, 2.0, 17):
        offset = circle.point(t) - centre
        assert abs(offset @ unit) < 1e-12
        assert np.linalg.norm(offset) == pytest.approx(0.15)


def test_via_points_by_time() -> None:
    source = ViaPoints([[0, 0, 0], [1, 0, 0], [1, 1, 0]], dwell_s=2.0)
    assert source.point(0.0)[0] == 0.0
    assert source.point(1.9)[0] == 0.0
    np.testing.assert_array_equal(source.point(2.0), [1, 0, 0])
    np.testing.assert_array_equal(source.point(3.9), [1, 0, 0])
    np.testing.assert_array_equal(source.point(4.0), [1, 1, 0])
    np.testing.assert_array_equal(source.point(100.0), [1, 1, 0])  # the last one stays


def test_via_points_advance_when_reached_and_dwelled() -> None:
    source = ViaPoints([0, 0, 0, 0.1, 0, 0], dwell_s=0.5, tolerance=0.002)  # flat list (a ROS parameter)
    np.testing.assert_array_equal(source.point(0.0, position=[0.05, 0, 0]), [0, 0, 0])  # not reached
    np.testing.assert_array_equal(source.point(10.0, position=[0.05, 0, 0]), [0, 0, 0])  # time alone: no
    np.testing.assert_array_equal(source.point(10.1, position=[0.001, 0, 0]), [0, 0, 0])  # reached: dwell
    np.testing.assert_array_equal(source.point(10.5, position=[0.0, 0, 0]), [0, 0, 0])
    np.testing.assert_array_equal(source.point(10.61, position=[0.0, 0, 0]), [0.1, 0, 0])
    assert source.index == 1


def test_via_points_loop() -> None:
    source = ViaPoints([[0, 0, 0], [1, 0, 0]], dwell_s=1.0, loop=True)
    assert [source.point(t)[0] for t in (0.0, 1.0, 2.0, 3.0)] == [0.0, 1.0, 0.0, 1.0]


def test_invalid_inputs_are_rejected() -> None:
    with pytest.raises(FicInputError, match="point"):
        FixedPoint([0, math.nan, 0])
    with pytest.raises(FicInputError, match="points"):
        ViaPoints([0, 0])
    with pytest.raises(FicInputError, match="points"):
        ViaPoints([[0, 0, math.inf]])
    with pytest.raises(FicInputError, match="dwell_s"):
        ViaPoints([[0, 0, 0]], dwell_s=-1.0)
    with pytest.raises(FicInputError, match="diameter"):
        Circle([0, 0, 0], diameter=0.0)
    with pytest.raises(FicInputError, match="period"):
        Circle([0, 0, 0], period=math.nan)
    with pytest.raises(FicInputError, match="normal"):
        Circle([0, 0, 0], normal=(0.0, 0.0, 0.0))
    with pytest.raises(FicInputError, match="centre"):
        Circle([0, math.nan, 0])
    for source in (FixedPoint([0, 0, 0]), ViaPoints([[0, 0, 0]]), Circle([0, 0, 0])):
        with pytest.raises(FicInputError, match="t"):
            source.point(math.nan)
    with pytest.raises(FicInputError, match="position"):
        ViaPoints([[0, 0, 0]]).point(0.0, position=[math.nan, 0, 0])


def test_a_via_point_is_reached_by_the_distance_to_it_then_dwelt_on() -> None:
    """With a position given, the dwell starts once the position is within the tolerance of the via-point (the
    distance |position - point|), and the next via-point follows dwell_s later; far away, it never starts."""
    source = ViaPoints([[0.5, 0.0, 0.3], [0.6, 0.0, 0.3]], dwell_s=0.5, tolerance=0.002)
    np.testing.assert_array_equal(source.point(0.0, position=[0.5, 0.0, 0.3005]), [0.5, 0.0, 0.3])
    np.testing.assert_array_equal(source.point(0.6, position=[0.5, 0.0, 0.3]), [0.6, 0.0, 0.3])
    far = ViaPoints([[0.5, 0.0, 0.3], [0.6, 0.0, 0.3]], dwell_s=0.5, tolerance=0.002)
    far.point(0.0, position=[0.4, 0.0, 0.3])
    np.testing.assert_array_equal(far.point(5.0, position=[0.4, 0.0, 0.3]), [0.5, 0.0, 0.3])


@settings(max_examples=80, deadline=None, derandomize=True)
@given(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).filter(lambda n: np.linalg.norm(n) > 1e-3),
       st.floats(-4.0, 4.0))
def test_any_circle_runs_counter_clockwise_about_its_normal_from_its_phase(normal, phase) -> None:
    """u x v = normal: seen from the normal's tip the circle turns counter-clockwise, at 2 pi r / period, on the
    plane through the centre; the point at phase + a quarter turn is the start point turned by 90 deg about n."""
    centre = np.array([0.4, -0.1, 0.3])
    circle = Circle(centre, diameter=0.2, period=4.0, normal=normal, phase=phase)
    unit = np.array(normal) / np.linalg.norm(normal)
    start, quarter = circle.point(0.0) - centre, circle.point(1.0) - centre
    np.testing.assert_allclose(np.cross(start, quarter), 0.01 * unit, atol=1e-12)   # r^2 n: a quarter turn about n
    assert abs(start @ unit) < 1e-12 and np.linalg.norm(start) == pytest.approx(0.1)
    back = circle.point(4.0) - centre
    np.testing.assert_allclose(back, start, atol=1e-12)


def test_the_default_circle_starts_at_x_and_its_phase_turns_the_start() -> None:
    centre = np.array([0.5, 0.0, 0.4])
    np.testing.assert_allclose(Circle(centre, phase=math.pi / 2).point(0.0), centre + [0.0, 0.1, 0.0], atol=1e-15)
    np.testing.assert_allclose(Circle(centre, normal=(0.0, 0.0, -1.0)).point(1.25), centre + [0.0, -0.1, 0.0],
                               atol=1e-15)   # seen from below, still counter-clockwise: -y after a quarter


def test_a_via_point_exactly_at_the_tolerance_is_reached_and_reset_starts_over() -> None:
    source = ViaPoints([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]], dwell_s=0.0, tolerance=0.25)
    np.testing.assert_array_equal(source.point(0.0, position=[0.0, 0.25, 0.0]), [0.5, 0.0, 0.0])   # reached
    assert source.index == 1
    source.reset()
    assert source.index == 0
    np.testing.assert_array_equal(source.point(0.0, position=[0.0, 0.2500001, 0.0]), [0.0, 0.0, 0.0])
    with pytest.raises(FicInputError, match="tolerance"):
        ViaPoints([[0.0, 0.0, 0.0]], tolerance=0.0)


def test_a_looping_sequence_reached_by_position_waits_to_reach_each_point_again() -> None:
    """Reached by position, after the last via-point the first is the target again, and its dwell starts only once
    it is reached (not at the moment the sequence wrapped)."""
    source = ViaPoints([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]], dwell_s=0.5, tolerance=0.002, loop=True)
    source.point(0.0, position=[0.0, 0.0, 0.0])
    np.testing.assert_array_equal(source.point(0.5, position=[0.0, 0.0, 0.0]), [0.1, 0.0, 0.0])
    source.point(1.0, position=[0.1, 0.0, 0.0])
    np.testing.assert_array_equal(source.point(1.5, position=[0.1, 0.0, 0.0]), [0.0, 0.0, 0.0])   # wrapped
    np.testing.assert_array_equal(source.point(2.5, position=[0.05, 0.0, 0.0]), [0.0, 0.0, 0.0])  # not reached
    assert source.index == 0


def test_a_circle_needs_a_positive_period_and_diameter() -> None:
    """Period 0 would turn the circle infinitely fast, diameter 0 is a point: both are refused, by name."""
    for changes, name in (({"period": 0.0}, "period"), ({"period": -5.0}, "period"), ({"diameter": -0.2}, "diameter")):
        with pytest.raises(FicInputError, match=name):
            Circle([0.4, 0.0, 0.3], **changes)
