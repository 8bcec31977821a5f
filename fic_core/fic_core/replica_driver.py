"""The replica's side of the driver behind its topics: which arm, which names, who adds gravity, which wrench frame,
and the torque ramp-down on stale joint states (docs/HARDWARE.md).

The values are the driver rows of the replica's parameters (fic_teleop_replica.driver_interface declares them; the
simulated Panda's in config/replica.yaml, franka_ros2's in its profile). fic_core.replica_station owns one.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .arm_profile import arm_profile, resolve_joint_names
from .joint_order import JointOrder
from .limits import PandaLimits
from .robot_model import RobotModel
from .stale_input_ramp import StaleInputRamp
from .torque_semantics import TorqueSemantics
from .wrench_frame import WrenchFrame


class ReplicaDriver:
    """The fic_core objects the driver parameters (``values``, by name) describe."""

    def __init__(self, values: Mapping[str, Any]) -> None:
        self.profile = arm_profile(values["arm_type"])
        self.joint_names = resolve_joint_names(self.profile, list(values["joint_names"] or []),
                                               values["joint_prefix"])
        self.joint_order = JointOrder(self.joint_names)
        self.semantics = TorqueSemantics(bool(values["gravity_compensated_by_robot"]))
        self.base_frame = str(values["base_frame"])
        self.wrench_frame = WrenchFrame(tuple(name for name in values["wrench_frame_ids"] if name),
                                        float(values["wrench_sign"]), tuple(values["wrench_reference_offset"]))
        timeout = float(values["joint_state_timeout"])
        self.ramp = StaleInputRamp(timeout, float(values["torque_ramp_time"])) if timeout > 0.0 else None
        self._rest = None
        self.published: np.ndarray | None = None  # the last command sent

    def limits(self, robot: RobotModel) -> PandaLimits:
        return self.profile.limits_for(robot.lower_position_limit, robot.upper_position_limit)

    def command(self, torque: np.ndarray, robot: RobotModel) -> np.ndarray:
        """The command to publish for the replica's tau at the state ``robot`` was last updated with."""
        if self.semantics.gravity_compensated_by_robot or self.ramp is not None:
            gravity = robot.gravity
            if self.ramp is not None:
                self._rest = self.semantics.rest_command(gravity)
            return self.semantics.command(torque, gravity)
        return torque

    def command_to_send(self, torque: np.ndarray | None, robot: RobotModel) -> np.ndarray | None:
        """The command for the loop's tau (``command``), or None: no tau, or the ramp owns the command until a
        valid joint state comes (a refused one repeats nothing)."""
        if torque is None or (self.ramp is not None and self.ramp.stale):
            return None
        self.published = self.command(torque, robot)
        return self.published

    def ramp_command(self, now: float) -> tuple[np.ndarray | None, bool]:
        """The ramp's command toward the gravity-only hold at the last state (None: nothing to send), and whether
        the ramp-down started now. A driver's forward controller would hold the last torque forever
        (fic_core.stale_input_ramp); at most 2 x 87 N m / ramp_time: inside the torque-rate limit."""
        started = self.ramp.check(now, self.published)
        if self.ramp.stale and self._rest is not None:
            self.published = self.ramp.command(now, self._rest)
            return self.published, started
        return None, started

    def describe(self) -> str:
        gravity = "left to the robot (tau - G)" if self.semantics.gravity_compensated_by_robot else "in the command"
        ramp = "off" if self.ramp is None else f"{self.ramp.timeout:g} s, ramp {self.ramp.ramp_time:g} s"
        return (f"arm {self.profile.name} ({', '.join(self.joint_names)}), gravity {gravity}, wrench frames "
                f"{list(self.wrench_frame.base_frame_ids)} sign {self.wrench_frame.sign:+g}, joint-state ramp-down "
                f"{ramp}")


__all__ = ["ReplicaDriver"]
