"""The replica's side of the driver behind its topics: which arm, which names, who adds gravity, which wrench frame,
and the torque ramp-down on stale joint states (docs/HARDWARE.md). Parameters and calls into fic_core only.

Defaults are the simulated Panda's (robot_node): ``arm_type`` panda, gravity in the command, the wrist sensor's
frame ``panda_link0``, no ramp-down (robot_node holds the arm itself when commands stop). The franka_ros2 profile
(config/profiles/franka_ros2/replica.yaml) flips them.
"""
from __future__ import annotations

import numpy as np
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor
from rclpy.node import Node

from fic_core.arm_profile import ARM_TYPES, arm_profile, resolve_joint_names
from fic_core.errors import FicInputError
from fic_core.joint_order import JointOrder
from fic_core.limits import PandaLimits
from fic_core.robot_model import RobotModel
from fic_core.stale_input_ramp import StaleInputRamp
from fic_core.torque_semantics import TorqueSemantics
from fic_core.wrench_frame import WrenchFrame

#: Parameters this module owns (fixed at start: a driver does not change under a running replica).
PARAMETERS = ("arm_type", "joint_names", "joint_prefix", "gravity_compensated_by_robot", "base_frame",
              "wrench_frame_ids", "wrench_sign", "wrench_reference_offset", "joint_state_timeout", "torque_ramp_time")


def _range(low: float, high: float, text: str) -> ParameterDescriptor:
    return ParameterDescriptor(description=text, read_only=True,
                               floating_point_range=[FloatingPointRange(from_value=low, to_value=high, step=0.0)])


class DriverInterface:
    """Declares the driver parameters on ``node`` and holds the fic_core objects they describe."""

    def __init__(self, node: Node) -> None:
        fixed = lambda text: ParameterDescriptor(description=text, read_only=True)  # noqa: E731
        node.declare_parameter("arm_type", "panda", fixed(f"the arm behind /joint_states: one of {ARM_TYPES} "
                                                          "(joint names and datasheet limits, fic_core.arm_profile)"))
        node.declare_parameter("joint_names", [""], fixed("the 7 arm joint names in order 1..7; empty: "
                                                          "<joint_prefix or arm_type>_joint1..7"))
        node.declare_parameter("joint_prefix", "", fixed("prefix of <prefix>_joint1..7 (empty: arm_type's)"))
        node.declare_parameter("gravity_compensated_by_robot", False, fixed(
            "the robot adds G(q) itself (a Franka under torque control): publish tau - G(q); Coriolis stays in "
            "the command either way (fic_core.torque_semantics)"))
        node.declare_parameter("base_frame", "panda_link0", fixed("frame_id of the replica's poses and F_R"))
        node.declare_parameter("wrench_frame_ids", ["panda_link0"], fixed(
            "frame_ids accepted on /ft_sensor/wrench as the base frame; another frame is refused (F_R = 0)"))
        node.declare_parameter("wrench_sign", 1.0, _range(-1.0, 1.0, "+1: the wrench is the environment's on the "
                                                          "robot; -1: the robot's on the environment"))
        node.declare_parameter("wrench_reference_offset", [0.0, 0.0, 0.0], fixed(
            "where the wrench's reference point is, from the TCP, in the TCP frame [m] (zero: at the TCP)"))
        node.declare_parameter("joint_state_timeout", 0.0, _range(0.0, 10.0, "no valid joint state for this long "
                               "(steady clock): ramp the command to the gravity-only hold [s]; 0: off (robot_node "
                               "holds the simulated arm itself)"))
        node.declare_parameter("torque_ramp_time", 0.5, _range(0.0, 10.0, "duration of that ramp [s]"))
        value = lambda name: node.get_parameter(name).value  # noqa: E731
        self.profile = arm_profile(value("arm_type"))
        self.joint_names = resolve_joint_names(self.profile, list(value("joint_names") or []),
                                               value("joint_prefix"))
        self.joint_order = JointOrder(self.joint_names)
        self.semantics = TorqueSemantics(bool(value("gravity_compensated_by_robot")))
        self.base_frame = str(value("base_frame"))
        self.wrench_frame = WrenchFrame(tuple(name for name in value("wrench_frame_ids") if name),
                                        float(value("wrench_sign")), tuple(value("wrench_reference_offset")))
        timeout = float(value("joint_state_timeout"))
        self.ramp = StaleInputRamp(timeout, float(value("torque_ramp_time"))) if timeout > 0.0 else None
        self._rest = None

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

    def rest_command(self) -> np.ndarray | None:
        """The gravity-only hold at the last state (None before the first tick)."""
        return self._rest

    def describe(self) -> str:
        gravity = "left to the robot (tau - G)" if self.semantics.gravity_compensated_by_robot else "in the command"
        ramp = "off" if self.ramp is None else f"{self.ramp.timeout:g} s, ramp {self.ramp.ramp_time:g} s"
        return (f"arm {self.profile.name} ({', '.join(self.joint_names)}), gravity {gravity}, wrench frames "
                f"{list(self.wrench_frame.base_frame_ids)} sign {self.wrench_frame.sign:+g}, joint-state ramp-down "
                f"{ramp}")


__all__ = ["DriverInterface", "PARAMETERS", "FicInputError"]
