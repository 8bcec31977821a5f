"""The parameter rows of the replica's driver (which arm, which names, who adds gravity, which wrench frame, the
torque ramp-down on stale joint states; docs/HARDWARE.md). What they mean is fic_core.replica_driver's.

config/replica.yaml's values are the simulated Panda's (robot_node): ``arm_type`` panda, gravity in the command,
the wrist sensor's frame ``panda_link0``, no ramp-down (robot_node holds the arm itself when commands stop). The
franka_ros2 profile (config/profiles/franka_ros2/replica.yaml) flips them.
"""
from __future__ import annotations

from fic_core.arm_profile import ARM_TYPES
from fic_core.errors import FicInputError
from fic_core.replica_driver import ReplicaDriver
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


#: The driver's semantics, built from these rows (fic_core.replica_driver); the replica station owns one.
DriverInterface = ReplicaDriver


__all__ = ["DRIVER_PARAMETERS", "DriverInterface", "FicInputError", "ReplicaDriver"]
