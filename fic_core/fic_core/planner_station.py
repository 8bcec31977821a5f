"""The planner side's logic (paper Eqs. 5-6): what the planner node runs and the in-process runner steps.

    trajectory source x_t(t) (circle, fixed point, via-points: fic_core.trajectories) --> PlannerSchedule (stepped
    in periods no longer than the publish period, whatever the timer does) --> HarmonicPlanner --> x_d'', its
    acceleration and the fixed orientation, at ``update(now)``

The trajectory's clock starts at ``start_time`` (an absolute time another side can share: the operator script
plans its moves around the circle's obstacles) or, when that is negative, ``start_delay`` after the station is
built. The station takes its parameters as one typed object, ``PlannerParameters``, generated from the planner's
table (``PLANNER_PARAMETERS``, the rows the planner node declares; fic_core.parameter_row). ``configure`` is the
run-time parameter dispatch: a new trajectory restarts its clock (the planner moves harmonically from where it is),
a new natural_frequency or max_velocity restarts the planner at rest where it is; every value is checked before any
is applied (FicInputError names the bad one).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import FicInputError
from .parameter_row import ParameterRow, number, numbers, parameter_set, rows_by_name, switch, text
from .planner import HarmonicPlanner
from .planner_schedule import PlannerSchedule, TrajectorySource
from .quaternion import unit_quaternion
from .stopped_trajectory import StoppedTrajectory
from .trajectories import Circle, FixedPoint, ViaPoints

TRAJECTORIES = ("circle", "fixed", "via_points")
TRAJECTORY_PARAMETERS = ("trajectory", "circle_centre", "circle_diameter", "circle_period", "circle_normal",
                         "circle_phase", "fixed_point", "via_points", "via_dwell", "via_tolerance", "via_loop")
HARMONIC_PLANNER_PARAMETERS = ("natural_frequency", "max_velocity")
Notice = tuple[str, str]

#: Every parameter of the planner, in the order the planner node declares them (config/planner.yaml's keys).
PLANNER_PARAMETERS: dict[str, ParameterRow] = rows_by_name(
    text("trajectory", f"trajectory source: one of {TRAJECTORIES}"),
    numbers("circle_centre", "centre of the circle [m] in panda_link0 (config: the E1 scene's, between the "
                             "obstacles)"),
    number("circle_diameter", 0.001, 2.0, "circle diameter [m] (paper: 0.20)"),
    number("circle_period", 0.1, 600.0, "circle period [s] (paper: 5)"),
    numbers("circle_normal", "normal of the circle's plane (+z: horizontal, counter-clockwise from above)"),
    number("circle_phase", -2 * math.pi, 2 * math.pi, "start angle [rad]"),
    numbers("fixed_point", "target of the fixed trajectory [m] in panda_link0"),
    numbers("via_points", "via-points as a flat list x0, y0, z0, x1, ... [m] in panda_link0"),
    number("via_dwell", 0.0, 600.0, "time a via-point is held once reached before the next [s]"),
    number("via_tolerance", 1e-5, 1.0, "a via-point is reached within this [m]"),
    switch("via_loop", "start the via-points again after the last one"),
    number("natural_frequency", 0.1, 100.0, "w_n of the planner [rad/s] (Eq. 5)"),
    number("max_velocity", 0.001, 1.7, "v_d: desired tangential velocity and speed limit [m/s] (Eq. 6); Panda "
                                       "TCP <= 1.7"),
    numbers("orientation", "fixed desired orientation [x, y, z, w] in panda_link0 (gripper down: a rotation of pi "
                           "about x, as in the Panda's ready pose)"),
    numbers("start_position", "x_d'' at start [m]; unset or empty: the trajectory's first point", read_only=True,
            optional=True),
    number("start_delay", 0.0, 3600.0, "the trajectory's clock starts this long after the node [s]", True),
    number("start_time", -1.0, 1e10, "node-clock time at which the trajectory's clock starts [s] (sim time with "
                                     "use_sim_time); negative: start_delay after the node starts", True),
    number("stop_time", -1.0, 1e10, "node-clock time at which the trajectory's clock stops and x_d'' comes to rest "
                                    "on its point there (a run's quiet tail) [s]; negative: never", True),
    number("publish_rate", 1.0, 5000.0, "/planner/desired_pose rate [Hz]", True),
    number("diagnostics_rate", 0.01, 100.0, "/diagnostics rate [Hz]", True),
    text("frame_id", "frame of /planner/desired_pose", read_only=True),
)
#: The planner's parameters as one typed object, one field a row of PLANNER_PARAMETERS (fic_core.parameter_row):
#: ``PlannerParameters.from_values(values)`` checks every value and refuses a name no row has, naming the nearest.
PlannerParameters = parameter_set("PlannerParameters", __name__, "planner", PLANNER_PARAMETERS.values(),
                                  "The planner's parameters (PLANNER_PARAMETERS), checked, one field a row.")
#: Fixed at start: the timers and the trajectory's origin are made from them.
READ_ONLY = tuple(name for name, row in PLANNER_PARAMETERS.items() if row.read_only)


def make_source(p: PlannerParameters) -> Circle | FixedPoint | ViaPoints:
    """The trajectory source named by ``p.trajectory`` (FicInputError on bad values)."""
    kind = p.trajectory
    if kind == "circle":
        return Circle(p.circle_centre, p.circle_diameter, p.circle_period, normal=p.circle_normal,
                      phase=p.circle_phase)
    if kind == "fixed":
        return FixedPoint(p.fixed_point)
    if kind == "via_points":
        return ViaPoints(p.via_points, p.via_dwell, p.via_tolerance, p.via_loop)
    raise FicInputError(f"trajectory must be one of {TRAJECTORIES}, got {kind!r}")


@dataclass
class PlannerSetPoint:
    """x_d'' at a step: position [m], orientation (x, y, z, w) and the planner's acceleration [m/s^2]."""

    position: NDArray[np.float64]
    orientation: NDArray[np.float64]
    acceleration: NDArray[np.float64]


class PlannerStation:
    """x_d'' for the planner's parameters (module docstring), from clock time ``now`` on. ``source``: a trajectory
    source other than the parameters' (the runner's lap-varying circle). ``parameters`` is kept as the station runs
    them now (``configure`` replaces it)."""

    def __init__(self, parameters: PlannerParameters, now: float, source: TrajectorySource | None = None) -> None:
        p = self.parameters = parameters
        self.orientation = unit_quaternion(p.orientation)
        planner = HarmonicPlanner(p.natural_frequency, p.max_velocity)
        source = make_source(p) if source is None else source
        start = list(p.start_position or [])
        planner.reset(start if start else source.point(0.0))
        origin = p.start_time if p.start_time >= 0.0 else now + p.start_delay
        if p.stop_time >= 0.0:   # a quiet tail: the trajectory's clock stops there (StoppedTrajectory)
            source = StoppedTrajectory(source, max(p.stop_time - origin, 0.0))
        self.schedule = PlannerSchedule(planner, source, origin, 1.0 / p.publish_rate)
        self.published = 0

    @property
    def planner(self) -> HarmonicPlanner:
        return self.schedule.planner

    def update(self, now: float) -> PlannerSetPoint:
        """The planner advanced to clock time ``now``: x_d'' to publish."""
        position = self.schedule.advance(now)
        self.published += 1
        return PlannerSetPoint(position, self.orientation, self.planner.acceleration)

    def configure(self, changes: Mapping[str, Any], now: float) -> list[Notice]:
        """Apply run-time changes at clock time ``now``, all or none (FicInputError names the bad one). Names
        that are not the planner's (rclpy's own, such as use_sim_time) are left alone."""
        for name, new in changes.items():
            if name in READ_ONLY:
                raise FicInputError(f"{name} is fixed at start")
            if isinstance(new, float) and not math.isfinite(new):
                raise FicInputError(f"{name} must be finite, got {new}")
        changes = {name: new for name, new in changes.items() if name in PLANNER_PARAMETERS}
        values = self.parameters.replaced(changes)   # each value checked by its row
        try:
            source = make_source(values) if any(n in TRAJECTORY_PARAMETERS for n in changes) else None
            planner = (HarmonicPlanner(values.natural_frequency, values.max_velocity)
                       if any(n in HARMONIC_PLANNER_PARAMETERS for n in changes) else None)
            orientation = unit_quaternion(changes["orientation"]) if "orientation" in changes else None
        except (ValueError, TypeError) as error:
            raise FicInputError(str(error)) from error
        notices: list[Notice] = []
        if source is not None:
            self.schedule.restart_trajectory(source, now)
            notices.append(("info", f"trajectory changed to {values.trajectory}: its clock restarts"))
        if planner is not None:
            self.schedule.retune(planner)
            notices.append(("info", f"planner retuned: w_n = {values.natural_frequency} rad/s, "
                                    f"v_d = {values.max_velocity} m/s (restarts at rest where it is)"))
        if orientation is not None:
            self.orientation = orientation
        self.parameters = values
        return notices

    def diagnostic_values(self) -> dict[str, str]:
        planner, target = self.planner, self.schedule.target
        return {"trajectory": str(self.parameters.trajectory),
                "target": " ".join(f"{v:.4f}" for v in target),
                "position": " ".join(f"{v:.4f}" for v in planner.position),
                "tracking_lag_m": f"{np.linalg.norm(target - planner.position):.4f}",
                "speed_m_s": f"{np.linalg.norm(planner.velocity):.4f}",
                "phase": " ".join(str(int(p)) for p in planner.phase),
                "published": str(self.published)}


__all__ = ["HARMONIC_PLANNER_PARAMETERS", "PLANNER_PARAMETERS", "READ_ONLY", "TRAJECTORIES", "TRAJECTORY_PARAMETERS",
           "PlannerParameters", "PlannerSetPoint", "PlannerStation", "make_source"]
