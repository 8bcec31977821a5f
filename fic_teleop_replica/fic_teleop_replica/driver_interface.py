"""The replica's side of the driver behind its topics: which arm, which names, who adds gravity, which wrench frame,
and the torque ramp-down on stale joint states (docs/HARDWARE.md). Parameter rows and calls into fic_core only.

config/replica.yaml's values are the simulated Panda's (robot_node): ``arm_type`` panda, gravity in the command,
the wrist sensor's frame ``panda_link0``, no ramp-down (robot_node holds the arm itself when commands stop). The franka_ros2 profile
(config/profiles/franka_ros2/replica.yaml) flips them.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from fic_core.arm_profile import ARM_TYPES, arm_profile, resolve_joint_names
from fic_core.errors import FicInputError
from fic_core.joint_order import JointOrder
from fic_core.limits import PandaLimits
from fic_core.robot_model import RobotModel
from fic_core.stale_input_ramp import StaleInputRamp
from fic_core.torque_semantics import TorqueSemantics
from fic_core.wrench_frame import WrenchFrame
from fic_teleop_runtime.parameters import number, numbers, switch, text, texts

#: The parameters this module owns, fixed at start: a driver does not change under a running replica.
DRIVER_PARAMETERS = (
    text("arm_type", f"the arm behind /joint_states: one of {ARM_TYPES} (joint names and datasheet limits, "
                     "fic_core.arm_profile)", read_only=True),
    texts("joint_names", "the 7 arm joint names in order 1..7; empty: <joint_prefix or arm_type>_joint1..7",
          read_only=True),
    text("joint_prefix", "prefix of <prefix>_joint1..7 (empty: arm_type's)", read_only=True),
    switch("gravity_compensated_by_robot", "the robot adds G(q) itself (a Franka under torque control): publish "
                                           "tau - G(q); Coriolis stays in the command either way "
                                           "(fic_core.torque_semantics)", read_only=True),
    text("base_frame", "frame_id of the replica's poses and F_R", read_only=True),
    texts("wrench_frame_ids", "frame_ids accepted on /ft_sensor/wrench as the base frame; another frame is "
                              "refused (F_R = 0)", read_only=True),
    number("wrench_sign", -1.0, 1.0, "+1: the wrench is the environment's on the robot; -1: the robot's on the "
                                     "environment", read_only=True),
    numbers("wrench_reference_offset", "where the wrench's reference point is, from the TCP, in the TCP frame [m] "
                                       "(zero: at the TCP)", read_only=True),
    number("joint_state_timeout", 0.0, 10.0, "no valid joint state for this long (steady clock): ramp the command "
                                             "to the gravity-only hold [s]; 0: off (robot_node holds the simulated "
                                             "arm itself)", read_only=True),
    number("torque_ramp_time", 0.0, 10.0, "duration of that ramp [s]", read_only=True),
)


class DriverInterface:
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


__all__ = ["DRIVER_PARAMETERS", "DriverInterface", "FicInputError"]
