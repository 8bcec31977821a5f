"""Trajectory sources for the harmonic planner: the next trajectory point x_t(t) (paper Sec. II-D).

Every source has ``point(t, position=None) -> NDArray(3)``: ``t`` is the time [s] since the trajectory
started, ``position`` optionally the planner's current output x_d'' (used by ViaPoints to know when a
via-point is reached; the others ignore it).

Frames: the points are absolute positions in the robot base frame (panda_link0). The planner's output x_d''
is superimposed on the operator's offset at the replica (x_d = x_d' + x_d''; paper Eq. 7), with x_d' = 0 when
the operator has not moved, so x_d'' is the absolute desired TCP position of the autonomous task and the
operator's command is a displacement on top of it. The planner starts from wherever it is reset to (the
replica's start TCP position) and moves harmonically to the trajectory's first point.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.errors import FicInputError, finite_array, finite_scalar

#: The paper's circle (Sec. III-B): 0.20 m diameter, 5 s period.
PAPER_CIRCLE_DIAMETER = 0.20
PAPER_CIRCLE_PERIOD = 5.0


class FixedPoint:
    """A constant target."""

    def __init__(self, point: ArrayLike) -> None:
        self._point = finite_array("point", point, (3,))

    def point(self, t: float, position: ArrayLike | None = None) -> NDArray[np.float64]:
        finite_scalar("t", t)
        return self._point.copy()


class ViaPoints:
    """A sequence of via-points, each held until reached (or for a dwell time), then the next one.

    With a ``position`` given to ``point``, a via-point is reached when the position is within ``tolerance`` of
    it; the source then waits ``dwell_s`` more before moving on. Without a position the schedule is by time
    only: each via-point is the target for ``dwell_s``. The last via-point stays the target (or, with
    ``loop=True``, the sequence starts again).
    """

    def __init__(self, points: ArrayLike, dwell_s: float = 1.0, tolerance: float = 0.002, loop: bool = False) -> None:
        array = finite_array("points", points)
        if array.ndim == 1 and array.size % 3 == 0:
            array = array.reshape(-1, 3)  # a flat list x0, y0, z0, x1, ... (a ROS double-array parameter)
        if array.ndim != 2 or array.shape[1] != 3 or array.shape[0] < 1:
            raise FicInputError(f"points must be N x 3 (or a flat list of 3*N values), got shape {array.shape}")
        self._points = array
        self._dwell_s = finite_scalar("dwell_s", dwell_s, minimum=0.0)
        self._tolerance = finite_scalar("tolerance", tolerance, minimum=0.0, minimum_inclusive=False)
        self._loop = bool(loop)
        self.reset()

    def reset(self) -> None:
        self._index = 0
        self._since: float | None = None  # time the current via-point became active (time mode) or was reached

    @property
    def index(self) -> int:
        """Index of the current via-point."""
        return self._index

    @property
    def points(self) -> NDArray[np.float64]:
        return self._points.copy()

    def point(self, t: float, position: ArrayLike | None = None) -> NDArray[np.float64]:
        t = finite_scalar("t", t)
        current = self._points[self._index]
        if position is None:
            reached = True  # time schedule: the dwell starts when the via-point becomes active
        else:
            reached = float(np.linalg.norm(finite_array("position", position, (3,)) - current)) <= self._tolerance
        if reached and self._since is None:
            self._since = t
        if self._since is not None and t - self._since >= self._dwell_s:
            last = self._points.shape[0] - 1
            if self._index < last or self._loop:
                self._index = 0 if self._index == last else self._index + 1
                self._since = t if position is None else None
        return self._points[self._index].copy()


class Circle:
    """The paper's circle: x_t(t) = centre + r*(cos(phi)*u + sin(phi)*v), phi = phase + 2*pi*t/period.

    ``u`` and ``v`` span the plane normal to ``normal`` (right-handed: u x v = normal). For the default normal
    +z, u = +x and v = +y, so the circle starts at centre + r*x and runs counter-clockwise seen from above.
    """

    def __init__(self, centre: ArrayLike, diameter: float = PAPER_CIRCLE_DIAMETER,
                 period: float = PAPER_CIRCLE_PERIOD, normal: ArrayLike = (0.0, 0.0, 1.0), phase: float = 0.0) -> None:
        self._centre = finite_array("centre", centre, (3,))
        self._radius = 0.5 * finite_scalar("diameter", diameter, minimum=0.0, minimum_inclusive=False)
        self._period = finite_scalar("period", period, minimum=0.0, minimum_inclusive=False)
        self._phase = finite_scalar("phase", phase)
        normal = finite_array("normal", normal, (3,))
        length = float(np.linalg.norm(normal))
        if length < 1e-9:
            raise FicInputError(f"normal must be a non-zero vector, got {normal}")
        normal = normal / length
        # u: the base axis least aligned with the normal, made orthogonal to it; v completes the frame.
        seed = np.eye(3)[int(np.argmin(np.abs(normal)))] if abs(normal[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
        u = seed - normal * float(seed @ normal)
        self._u = u / float(np.linalg.norm(u))
        self._v = np.cross(normal, self._u)

    @property
    def centre(self) -> NDArray[np.float64]:
        return self._centre.copy()

    @property
    def radius(self) -> float:
        return self._radius

    @property
    def period(self) -> float:
        return self._period

    @property
    def speed(self) -> float:
        """Tangential speed [m/s] = 2*pi*r/period (0.126 m/s for the paper's circle)."""
        return 2.0 * math.pi * self._radius / self._period

    def point(self, t: float, position: ArrayLike | None = None) -> NDArray[np.float64]:
        angle = self._phase + 2.0 * math.pi * finite_scalar("t", t) / self._period
        return self._centre + self._radius * (math.cos(angle) * self._u + math.sin(angle) * self._v)
