"""Guidance fixtures: a plane or a line that the replica's goal is guided onto (beyond the paper; docs/TOOLS.md,
"The operator's tools").

A fixture lives where x_d' lives: in the teleoperated offset's coordinates (panda_link0's axes, the origin where
x_d' = 0), given by a point p and a unit direction d, the plane's normal or the line's direction. It projects the
replica's goal x_d' onto itself,

    plane:  P(x) = x - d (d . (x - p))          line:  P(x) = p + d (d . (x - p))

and renders at the handle a spring toward the projection with a damper on the handle's velocity across the
fixture, bounded in norm:

    f_g = sat( K (P(x_d') - x_d') - B across(v_M), F_max )

The replica's goal is the projection: the master station sends P(x_d') (and takes the goal to a new fixture's
projection at a bounded speed when one is switched, fic_core.master_station), so the arm moves on the plane or
the line whatever the hand does across it, while the handle's x_d' stays the operator's and the spring tells the
hand how far it is off. The handle's axes are the base
frame's (the master's convention), so the force pulls the handle the way that brings x_d' onto the fixture in
both teleoperation modes. In the offset mode the handle feels the spring as K s_M.
"""
from __future__ import annotations

from enum import IntEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_array, finite_scalar
from .norm_bound import norm_bounded


class FixtureKind(IntEnum):
    """Values as fic_teleop_msgs/OperatorTools' FIXTURE_* constants."""

    NONE = 0
    PLANE = 1
    LINE = 2


#: The names the ``guidance_fixture`` parameter takes.
FIXTURE_NAMES = {kind.name.lower(): kind for kind in FixtureKind}


def fixture_kind(name: str) -> FixtureKind:
    if name not in FIXTURE_NAMES:
        raise FicInputError(f"guidance_fixture must be one of {', '.join(FIXTURE_NAMES)}, got {name!r}")
    return FIXTURE_NAMES[name]


class GuidanceFixture:
    """A plane or a line in x_d' coordinates and its guidance force (module docstring)."""

    def __init__(self, kind: FixtureKind | str, point: ArrayLike, direction: ArrayLike, *, stiffness: float,
                 damping: float, max_force: float) -> None:
        self.kind = fixture_kind(kind) if isinstance(kind, str) else FixtureKind(kind)
        if self.kind == FixtureKind.NONE:
            raise FicInputError("a guidance fixture is a plane or a line")
        self.point = finite_array("guidance_point", point, (3,)).copy()
        direction = finite_array("guidance_direction", direction, (3,))
        length = float(np.linalg.norm(direction))
        if length < 1e-9:
            raise FicInputError(f"guidance_direction must not be zero, got {list(direction)}")
        self.direction = direction / length
        self.stiffness = finite_scalar("guidance_stiffness", stiffness, minimum=0.0)
        self.damping = finite_scalar("guidance_damping", damping, minimum=0.0)
        self.max_force = finite_scalar("guidance_max_force", max_force, minimum=0.0)

    def across(self, vector: NDArray[np.float64]) -> NDArray[np.float64]:
        """The part of ``vector`` that leaves the fixture: along the plane's normal, or off the line's direction."""
        along = self.direction * float(self.direction.dot(vector))
        return along if self.kind == FixtureKind.PLANE else vector - along

    def projection(self, goal: NDArray[np.float64]) -> NDArray[np.float64]:
        """P(x_d'): the point of the fixture nearest the goal."""
        return goal - self.across(goal - self.point)

    def force(self, goal: NDArray[np.float64], handle_velocity: NDArray[np.float64]) -> NDArray[np.float64]:
        """f_g [N] for the goal x_d' [m] and the handle's velocity [m/s] (finite, shape (3,))."""
        spring = self.across(goal - self.point) * -self.stiffness
        return norm_bounded(spring - self.across(handle_velocity) * self.damping, self.max_force)
