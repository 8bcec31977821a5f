"""The replica's side of the driver behind its topics: which arm, which names, who adds gravity, which wrench frame,
and the torque ramp-down on stale joint states (docs/HARDWARE.md).

The values are the driver rows of the replica's parameters (``DRIVER_PARAMETERS``, part of the table the replica
node declares, fic_core.replica_station): config/replica.yaml's are the simulated Panda's (robot_node): ``arm_type``
panda, gravity in the command, the wrist sensor's frame ``panda_link0``, no ramp-down (robot_node holds the arm
itself when commands stop); the franka_ros2 profile (config/profiles/franka_ros2/replica.yaml) flips them.
fic_core.replica_station owns one ReplicaDriver, built from its ``DriverParameters``.
"""
from __future__ import annotations

import numpy as np

from .arm_profile import ARM_TYPES, arm_profile, resolve_joint_names
from .joint_order import JointOrder
from .limits import PandaLimits
from .parameter_row import ParameterRow, number, numbers, parameter_set, rows_by_name, switch, text, texts
from .robot_model import RobotModel
from .stale_input_ramp import StaleInputRamp
from .torque_semantics import TorqueSemantics
from .wrench_frame import WrenchFrame

#: The driver's parameters, fixed at start: a driver does not change under a running replica.
DRIVER_PARAMETERS: dict[str, ParameterRow] = rows_by_name(
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
    switch("robot_in_process", "the simulated robot runs in the replica's process and calls its control step with "
                               "each joint state and F/T reading, taking the torque back without DDS (a node group "
                               "with the robot's controller_in_process; fic_teleop_runtime.in_process_link)",
           read_only=True),
)
#: The driver's rows as one typed object (fic_core.parameter_row.parameter_set).
DriverParameters = parameter_set("DriverParameters", __name__, "driver", DRIVER_PARAMETERS.values(),
                                 "The replica driver's parameters (DRIVER_PARAMETERS), checked, one field a row.")


class ReplicaDriver:
    """The fic_core objects the driver parameters describe."""

    def __init__(self, parameters: DriverParameters) -> None:
        p = parameters
        self.profile = arm_profile(p.arm_type)
        self.joint_names = resolve_joint_names(self.profile, list(p.joint_names or []), p.joint_prefix)
        self.joint_order = JointOrder(self.joint_names)
        self.semantics = TorqueSemantics(p.gravity_compensated_by_robot)
        self.base_frame = p.base_frame
        self.wrench_frame = WrenchFrame(tuple(name for name in p.wrench_frame_ids if name), p.wrench_sign,
                                        tuple(p.wrench_reference_offset))
        self.ramp = StaleInputRamp(p.joint_state_timeout, p.torque_ramp_time) if p.joint_state_timeout > 0.0 \
            else None
        self.in_process = p.robot_in_process   # the node reads its joint states from the robot's own thread
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
                f"{ramp}{', the robot in this process' if self.in_process else ''}")


__all__ = ["ReplicaDriver"]
