"""The test's side of a robot node (test/nodes/test_robot_node.py, test_robot_command_state_age.py): the node started
from its installed executable, and a controller that answers every joint state."""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin
import rclpy
from conftest import CONFIG, NodeProcess, installed_executable
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from fic_core.panda_description import load_pinocchio_model

QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=50)


def robot_node_command() -> list[str]:
    """The installed executable (what `ros2 run sim_bridge robot_node` starts), or the module from source."""
    path = installed_executable("sim_bridge", "robot_node")
    if path.exists():
        return [str(path)]
    return [sys.executable, "-m", "sim_bridge.robot.robot_node"]


def start_robot(ros_env: dict[str, str], tmp_path: Path, **params) -> NodeProcess:
    env = dict(ros_env)
    command = robot_node_command() + ["--ros-args", "--params-file", str(CONFIG / "robot.yaml")]
    for key, value in params.items():
        command += ["-p", f"{key}:={value}"]
    return NodeProcess(command, env, tmp_path / "robot_node.log")


class Controller:
    """Answers every joint state with gravity compensation + damping (Pinocchio), like the replica would."""

    def __init__(self, context) -> None:
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64MultiArray

        self.node = rclpy.create_node("test_controller", context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.model, self.data, _ = load_pinocchio_model()
        self.publisher = self.node.create_publisher(Float64MultiArray, "/effort_controller/commands", QOS)
        self.node.create_subscription(JointState, "/joint_states", self._on_state, QOS)
        self.states: list = []
        self.sent: list[np.ndarray] = []
        self.answering = True
        self.push = np.zeros(7)   # added to every answer (a controller gone wrong)
        self._message = Float64MultiArray

    def _on_state(self, message) -> None:
        self.states.append(message)
        if self.answering:
            q, qd = np.array(message.position), np.array(message.velocity)
            torque = pin.computeGeneralizedGravity(self.model, self.data,
                                                   q) - 2.0 * qd + 0.5 * np.sin(len(self.sent) / 50.0)
            torque = torque + self.push
            self.sent.append(torque)
            self.publisher.publish(self._message(data=torque.tolist()))

    def send_raw(self, values: list[float]) -> None:
        self.publisher.publish(self._message(data=values))

    def spin_until(self, condition, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if condition():
                return True
            self.executor.spin_once(timeout_sec=0.05)
        return condition()


def stamp_ns(message) -> int:
    return message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
