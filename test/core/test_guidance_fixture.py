"""Guidance fixtures (fic_core.guidance_fixture): the projection onto a plane and a line, checked as projections
(on the fixture, the residual across it, idempotent), and the bounded spring-damper toward it."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.errors import FicInputError
from fic_core.guidance_fixture import FixtureKind, GuidanceFixture

coordinates = st.floats(-0.5, 0.5, allow_nan=False)
vectors = st.tuples(coordinates, coordinates, coordinates).map(np.array)
directions = vectors.filter(lambda v: np.linalg.norm(v) > 1e-3)


@settings(max_examples=200, deadline=None)
@given(kind=st.sampled_from(["plane", "line"]), point=vectors, direction=directions, goal=vectors)
def test_the_projection_is_the_nearest_point_of_the_fixture(kind, point, direction, goal) -> None:
    fixture = GuidanceFixture(kind, point, direction, stiffness=100.0, damping=1.0, max_force=4.0)
    projected = fixture.projection(goal)
    unit = direction / np.linalg.norm(direction)
    residual = goal - projected
    if kind == "plane":
        assert abs(unit @ (projected - point)) < 1e-12            # on the plane
        assert np.linalg.norm(np.cross(residual, unit)) < 1e-12  # the residual along the normal
    else:
        assert np.linalg.norm(np.cross(projected - point, unit)) < 1e-12   # on the line
        assert abs(residual @ unit) < 1e-12                                # the residual across it
    np.testing.assert_allclose(fixture.projection(projected), projected, atol=1e-12)
    # Nearest: no other point of the fixture is closer (two samples along it).
    along = np.cross(unit, [1.0, 0.0, 0.0]) if kind == "plane" else unit
    if np.linalg.norm(along) > 1e-6:
        for step in (-0.01, 0.01):
            assert np.linalg.norm(goal - (projected + step * along / np.linalg.norm(along))) >= \
                np.linalg.norm(residual)


def test_the_force_is_a_bounded_spring_toward_the_fixture_and_a_damper_across_it() -> None:
    plane = GuidanceFixture("plane", [0.0, 0.0, 0.1], [0.0, 0.0, 2.0], stiffness=100.0, damping=1.0, max_force=4.0)
    goal = np.array([0.3, -0.2, 0.12])          # 2 cm above the plane, anywhere along it
    np.testing.assert_allclose(plane.force(goal, np.zeros(3)), [0.0, 0.0, -2.0])
    # Motion along the plane is free; across it, damped.
    np.testing.assert_allclose(plane.force(goal, np.array([0.5, 0.5, 0.0])), [0.0, 0.0, -2.0])
    np.testing.assert_allclose(plane.force(goal, np.array([0.0, 0.0, 0.5])), [0.0, 0.0, -2.5])
    # Bounded in norm: 10 cm off is 10 N of spring, rendered at 4 N.
    np.testing.assert_allclose(plane.force(np.array([0.0, 0.0, 0.2]), np.zeros(3)), [0.0, 0.0, -4.0])
    line = GuidanceFixture("line", [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], stiffness=100.0, damping=1.0, max_force=4.0)
    np.testing.assert_allclose(line.force(np.array([0.05, 0.01, -0.02]), np.array([0.3, 0.0, 0.0])),
                               [0.0, -1.0, 2.0])
    assert line.kind == FixtureKind.LINE


def test_bad_fixtures_are_refused() -> None:
    with pytest.raises(FicInputError, match="guidance_direction must not be zero"):
        GuidanceFixture("plane", [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], stiffness=100.0, damping=1.0, max_force=4.0)
    with pytest.raises(FicInputError, match="guidance_fixture must be one of none, plane, line"):
        GuidanceFixture("cylinder", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], stiffness=100.0, damping=1.0, max_force=4.0)
    with pytest.raises(FicInputError, match="guidance_point"):
        GuidanceFixture("line", [0.0, 0.0], [0.0, 0.0, 1.0], stiffness=100.0, damping=1.0, max_force=4.0)
    with pytest.raises(FicInputError, match="a plane or a line"):
        GuidanceFixture("none", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], stiffness=100.0, damping=1.0, max_force=4.0)
