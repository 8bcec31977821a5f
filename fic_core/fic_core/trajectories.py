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
                 period: float = PAPER_CIRCLE_PERIOD, *, normal: ArrayLike = (0.0, 0.0, 1.0),
                 phase: float = 0.0) -> None:
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


def _smoothstep(fraction: float) -> float:
    """Quintic smoothstep: 0 -> 1 with zero slope and curvature at both ends (a C2 blend between laps)."""
    u = min(max(fraction, 0.0), 1.0)
    return u ** 3 * (10.0 - 15.0 * u + 6.0 * u ** 2)


class LapVaryingCircle:
    """The paper's circle with its own period and diameter on every lap, so that no two laps are alike.

    Lap ``i`` lasts ``periods[i]``. Over it the angular speed blends from 2*pi / ``periods[i]`` to the next lap's
    2*pi / ``periods[i + 1]`` (the last lap's speed goes on) and the radius from ``diameters[i] / 2`` to
    ``diameters[i + 1] / 2``, both with a quintic smoothstep: the angle is C3 and the radius C2 in time, so the
    motion has no step in speed that an operator predicting a passing from the seen speed could not foresee, and a
    lap's angle is the mean of its two speeds times its duration (about 2*pi). After the last listed lap the last
    speed and diameter go on. Same frame as ``Circle`` (``u x v = normal``, start at ``phase``).

    A sweep that must not repeat its task draws the laps from a seed (``randomised``); the scene's obstacles stay on
    the path as long as the diameters stay within their width of the paper's 0.20 m.
    """

    def __init__(self, centre: ArrayLike, periods: ArrayLike, diameters: ArrayLike, *,
                 normal: ArrayLike = (0.0, 0.0, 1.0), phase: float = 0.0) -> None:
        self._centre = finite_array("centre", centre, (3,))
        self._periods = finite_array("periods", periods)
        self._diameters = finite_array("diameters", diameters)
        if self._periods.ndim != 1 or self._periods.size < 1 or np.any(self._periods <= 0.0):
            raise FicInputError(f"periods must be a non-empty list of positive seconds, got {self._periods}")
        if self._diameters.shape != (self._periods.size + 1,) or np.any(self._diameters <= 0.0):
            raise FicInputError(f"diameters must be {self._periods.size + 1} positive lengths (one more than the "
                                f"laps: each lap blends from its own to the next), got {self._diameters}")
        self._starts = np.concatenate([[0.0], np.cumsum(self._periods)])
        # Angular speed at each lap's start, one more for the last lap's end (its own: the speed goes on).
        self._speeds = 2.0 * math.pi / np.concatenate([self._periods, self._periods[-1:]])
        # The angle at each lap's start: a lap adds its duration times the mean of its end speeds.
        self._start_angles = np.concatenate([[0.0], np.cumsum(
            0.5 * self._periods * (self._speeds[:-1] + self._speeds[1:]))])
        self._phase = finite_scalar("phase", phase)
        # The plane's axes as Circle builds them (the same start point and direction for the same normal).
        frame = Circle(self._centre, 1.0, 1.0, normal=normal, phase=0.0)
        self._u = frame.point(0.0) - self._centre
        self._u = self._u / float(np.linalg.norm(self._u))
        self._v = frame.point(0.25) - self._centre
        self._v = self._v / float(np.linalg.norm(self._v))

    @classmethod
    def randomised(cls, centre: ArrayLike, draws: np.random.Generator, duration: float,
                   period_range: tuple[float, float] = (4.0, 6.0),
                   diameter_range: tuple[float, float] = (0.17, 0.23),
                   normal: ArrayLike = (0.0, 0.0, 1.0),
                   phase_ranges: tuple[tuple[float, float], ...] = ((0.0, 2.0 * math.pi),)) -> "LapVaryingCircle":
        """Laps drawn uniformly from the ranges until ``duration`` [s] is covered; the start angle uniformly in one
        of ``phase_ranges`` [rad], the range itself drawn with equal odds (arcs that keep the start off obstacles)."""
        duration = finite_scalar("duration", duration, minimum=0.0, minimum_inclusive=False)
        for name, (low, high) in (("period_range", period_range), ("diameter_range", diameter_range)):
            if not 0.0 < low <= high or not math.isfinite(high):
                raise FicInputError(f"{name} must be 0 < low <= high, got {(low, high)}")
        if not phase_ranges or any(not (math.isfinite(low) and math.isfinite(high) and low <= high)
                                   for low, high in phase_ranges):
            raise FicInputError(f"phase_ranges must be finite (low, high) pairs, got {phase_ranges}")
        periods: list[float] = []
        while sum(periods) < duration:
            periods.append(float(draws.uniform(*period_range)))
        diameters = draws.uniform(*diameter_range, size=len(periods) + 1)
        phase = float(draws.uniform(*phase_ranges[int(draws.integers(len(phase_ranges)))]))
        return cls(centre, periods, diameters, normal=normal, phase=phase)

    @property
    def periods(self) -> NDArray[np.float64]:
        return self._periods.copy()

    @property
    def diameters(self) -> NDArray[np.float64]:
        return self._diameters.copy()

    @property
    def phase(self) -> float:
        return self._phase

    def _lap(self, t: float) -> tuple[int, float]:
        """The lap running at ``t`` and the fraction of it done (past the last lap: the last one's period on)."""
        last = self._periods.size - 1
        index = min(int(np.searchsorted(self._starts, t, side="right")) - 1, last)
        index = max(index, 0)
        return index, (t - self._starts[index]) / self._periods[index]

    def angle(self, t: float) -> float:
        """The angle on the circle at ``t`` [rad], from ``phase``: the integral of the blended angular speed."""
        t = finite_scalar("t", t)
        index, fraction = self._lap(t)
        start, end, duration = self._speeds[index], self._speeds[index + 1], self._periods[index]
        if fraction < 0.0 or fraction > 1.0:   # before the first lap or past the last: the end speed goes on
            speed = start if fraction < 0.0 else end
            anchor = 0.0 if fraction < 0.0 else 1.0
            base = self._start_angles[index] + (0.0 if fraction < 0.0 else 0.5 * duration * (start + end))
            return self._phase + float(base + speed * duration * (fraction - anchor))
        u = fraction   # the integral of the quintic smoothstep from 0 to u is u^4 (5/2 - 3 u + u^2)
        travelled = duration * (start * u + (end - start) * u ** 4 * (2.5 - 3.0 * u + u * u))
        return self._phase + float(self._start_angles[index] + travelled)

    def radius(self, t: float) -> float:
        index, fraction = self._lap(finite_scalar("t", t))
        start, end = self._diameters[index], self._diameters[index + 1]
        return 0.5 * float(start + _smoothstep(fraction) * (end - start))

    def point(self, t: float, position: ArrayLike | None = None) -> NDArray[np.float64]:
        angle, radius = self.angle(t), self.radius(t)
        return self._centre + radius * (math.cos(angle) * self._u + math.sin(angle) * self._v)
