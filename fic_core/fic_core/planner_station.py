"""The planner side's logic (paper Eqs. 5-6): what the planner node runs and the in-process runner steps.

    trajectory source x_t(t) (circle, fixed point, via-points: fic_core.trajectories) --> PlannerSchedule (stepped
    in periods no longer than the publish period, whatever the timer does) --> HarmonicPlanner --> x_d'', its
    acceleration and the fixed orientation, at ``update(now)``

The trajectory's clock starts at ``start_time`` (an absolute time another side can share: the operator script
plans its moves around the circle's obstacles) or, when that is negative, ``start_delay`` after the station is
built. ``configure`` is the run-time parameter dispatch: a new trajectory restarts its clock (the planner moves
harmonically from where it is), a new natural_frequency or max_velocity restarts the planner at rest where it is;
every value is checked before any is applied (FicInputError names the bad one).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import FicInputError
from .planner import HarmonicPlanner
from .planner_schedule import PlannerSchedule, TrajectorySource
from .quaternion import unit_quaternion
from .stopped_trajectory import StoppedTrajectory
from .trajectories import Circle, FixedPoint, ViaPoints

TRAJECTORIES = ("circle", "fixed", "via_points")
TRAJECTORY_PARAMETERS = ("trajectory", "circle_centre", "circle_diameter", "circle_period", "circle_normal",
                         "circle_phase", "fixed_point", "via_points", "via_dwell", "via_tolerance", "via_loop")
PLANNER_PARAMETERS = ("natural_frequency", "max_velocity")
#: Fixed at start: the timers and the trajectory's origin are made from them.
READ_ONLY = ("publish_rate", "diagnostics_rate", "frame_id", "start_position", "start_delay", "start_time",
             "stop_time")
Notice = tuple[str, str]


def make_source(values: Mapping[str, Any]) -> Circle | FixedPoint | ViaPoints:
    """The trajectory source named by values['trajectory'] (FicInputError on bad values)."""
    kind = values["trajectory"]
    if kind == "circle":
        return Circle(values["circle_centre"], values["circle_diameter"], values["circle_period"],
                      normal=values["circle_normal"], phase=values["circle_phase"])
    if kind == "fixed":
        return FixedPoint(values["fixed_point"])
    if kind == "via_points":
        return ViaPoints(values["via_points"], values["via_dwell"], values["via_tolerance"], values["via_loop"])
    raise FicInputError(f"trajectory must be one of {TRAJECTORIES}, got {kind!r}")


@dataclass
class PlannerSetPoint:
    """x_d'' at a step: position [m], orientation (x, y, z, w) and the planner's acceleration [m/s^2]."""

    position: NDArray[np.float64]
    orientation: NDArray[np.float64]
    acceleration: NDArray[np.float64]


class PlannerStation:
    """x_d'' for a parameter mapping (config/planner.yaml's keys; module docstring), from clock time ``now`` on.
    ``source``: a trajectory source other than the parameters' (the runner's lap-varying circle)."""

    def __init__(self, values: Mapping[str, Any], now: float, source: TrajectorySource | None = None) -> None:
        self.parameters = dict(values)
        self.orientation = unit_quaternion(values["orientation"])
        planner = HarmonicPlanner(values["natural_frequency"], values["max_velocity"])
        source = make_source(values) if source is None else source
        start = list(values.get("start_position") or [])
        planner.reset(start if start else source.point(0.0))
        start_time = values["start_time"]
        origin = start_time if start_time >= 0.0 else now + values["start_delay"]
        stop_time = values.get("stop_time", -1.0)
        if stop_time >= 0.0:   # a quiet tail: the trajectory's clock stops there (StoppedTrajectory)
            source = StoppedTrajectory(source, max(stop_time - origin, 0.0))
        self.schedule = PlannerSchedule(planner, source, origin, 1.0 / values["publish_rate"])
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
        """Apply run-time changes at clock time ``now``, all or none (FicInputError names the bad one)."""
        for name, new in changes.items():
            if name in READ_ONLY:
                raise FicInputError(f"{name} is fixed at start")
            if isinstance(new, float) and not math.isfinite(new):
                raise FicInputError(f"{name} must be finite, got {new}")
        values = {**self.parameters, **changes}
        try:
            source = make_source(values) if any(n in TRAJECTORY_PARAMETERS for n in changes) else None
            planner = (HarmonicPlanner(values["natural_frequency"], values["max_velocity"])
                       if any(n in PLANNER_PARAMETERS for n in changes) else None)
            orientation = unit_quaternion(changes["orientation"]) if "orientation" in changes else None
        except (ValueError, TypeError) as error:
            raise FicInputError(str(error)) from error
        notices: list[Notice] = []
        if source is not None:
            self.schedule.restart_trajectory(source, now)
            notices.append(("info", f"trajectory changed to {values['trajectory']}: its clock restarts"))
        if planner is not None:
            self.schedule.retune(planner)
            notices.append(("info", f"planner retuned: w_n = {values['natural_frequency']} rad/s, "
                                    f"v_d = {values['max_velocity']} m/s (restarts at rest where it is)"))
        if orientation is not None:
            self.orientation = orientation
        self.parameters = values
        return notices

    def diagnostic_values(self) -> dict[str, str]:
        planner, target = self.planner, self.schedule.target
        return {"trajectory": str(self.parameters["trajectory"]),
                "target": " ".join(f"{v:.4f}" for v in target),
                "position": " ".join(f"{v:.4f}" for v in planner.position),
                "tracking_lag_m": f"{np.linalg.norm(target - planner.position):.4f}",
                "speed_m_s": f"{np.linalg.norm(planner.velocity):.4f}",
                "phase": " ".join(str(int(p)) for p in planner.phase),
                "published": str(self.published)}


__all__ = ["PLANNER_PARAMETERS", "READ_ONLY", "TRAJECTORIES", "TRAJECTORY_PARAMETERS", "PlannerSetPoint",
           "PlannerStation", "make_source"]
