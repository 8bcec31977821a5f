"""The live view's CDR decoding (fic_teleop_tools.recording.live_view) on bytes from an independent serialiser (the
rosbags library), and its /robot_description string read back by rosbags."""
from __future__ import annotations

import numpy as np
from rosbags.typesys import Stores, get_typestore

from fic_core.panda_description import ARM_JOINT_NAMES
from fic_teleop_tools.recording.live_view import _cdr_string, joint_positions

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


def _joint_state(names: list[str], positions: list[float], frame_id: str = "panda_link0") -> bytes:
    types = TYPESTORE.types
    header = types["std_msgs/msg/Header"](stamp=types["builtin_interfaces/msg/Time"](sec=12, nanosec=345),
                                          frame_id=frame_id)
    message = types["sensor_msgs/msg/JointState"](header=header, name=names, position=np.array(positions),
                                                  velocity=np.zeros(len(names)), effort=np.zeros(0))
    return bytes(TYPESTORE.serialize_cdr(message, "sensor_msgs/msg/JointState"))


def test_positions_come_back_in_the_arm_order_whatever_the_message_order():
    names = list(reversed(ARM_JOINT_NAMES)) + ["panda_finger_joint1"]
    positions = [0.1 * (i + 1) for i in range(len(names))]
    decoded = joint_positions(_joint_state(names, positions, frame_id="odd length frame"))
    expected = {name: value for name, value in zip(names, positions)}
    np.testing.assert_array_equal(decoded, [expected[name] for name in ARM_JOINT_NAMES])


def test_a_missing_joint_or_a_short_position_array_gives_none():
    assert joint_positions(_joint_state(list(ARM_JOINT_NAMES[:-1]), [0.0] * 6)) is None
    assert joint_positions(_joint_state(list(ARM_JOINT_NAMES), [0.0] * 3)) is None


def test_the_robot_description_string_reads_back_with_rosbags():
    text = "<robot name='panda'/>" * 3
    assert TYPESTORE.deserialize_cdr(_cdr_string(text), "std_msgs/msg/String").data == text
