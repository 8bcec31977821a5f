"""Which entry of a sensor_msgs/JointState is which arm joint, refused loudly when the names do not fit.

A driver publishes its joints in its own order (ros2_control's joint_state_broadcaster: the hardware's order;
franka_robot_state_broadcaster: the URDF's revolute joints) and under its own names (``panda_joint1..7`` in the
simulation, ``fr3_joint1..7`` behind franka_ros2). The replica takes the seven joints it expects by name; a
message without all of them, or with position and velocity arrays of another length than its names, is an
error whose message names what was expected and what came, so that a wrong ``arm_type`` or ``joint_names`` is
found from one log line.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .errors import FicInputError


class JointStateMapping:
    """Index arrays from message order to the model's joint order, cached per distinct name list."""

    def __init__(self, expected_names: tuple[str, ...]) -> None:
        if len(expected_names) != len(set(expected_names)) or not expected_names:
            raise FicInputError(f"expected joint names must be distinct and non-empty, got {list(expected_names)}")
        self.expected_names = tuple(expected_names)
        self._cache: dict[tuple[str, ...], NDArray[np.intp]] = {}

    def index(self, names: list[str] | tuple[str, ...], positions: int, velocities: int) -> NDArray[np.intp]:
        """Where each expected joint sits in a message with ``names`` and that many positions and velocities.

        Raises FicInputError naming the expected and the received names (or the mismatched counts)."""
        key = tuple(names)
        index = self._cache.get(key)
        if index is None:
            missing = [name for name in self.expected_names if name not in key]
            if missing:
                raise FicInputError(
                    f"joint names do not match: expected {list(self.expected_names)}, received {list(key)} "
                    f"(missing {missing}); set arm_type or joint_names to the driver's names")
            if len(set(key)) != len(key):
                raise FicInputError(f"joint names repeat: received {list(key)}")
            index = np.array([key.index(name) for name in self.expected_names], dtype=np.intp)
            self._cache[key] = index
        if positions != len(key) or velocities != len(key):
            raise FicInputError(
                f"joint state has {len(key)} names but {positions} positions and {velocities} velocities "
                f"(expected {list(self.expected_names)}, received {list(key)})")
        return index
