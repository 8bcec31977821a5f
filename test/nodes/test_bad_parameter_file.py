"""A malformed, mistyped or misspelt parameter file: the replica refuses to start with one clear log line (exit 2,
the launcher's "refused before anything started"), and the robot, left without commands, holds the arm still (its
watchdog) instead of letting it fall."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.nodes

MALFORMED = "/**:\n  ros__parameters:\n    translation_stiffness: [oops\n"
MISTYPED = "/**:\n  ros__parameters:\n    translation_stiffness: \"stiff\"\n"
# rclpy alone would ignore a key nobody declares: the arm would run at the default stiffness without a word.
MISSPELT = "/**:\n  ros__parameters:\n    translaton_stiffness: 400.0\n"


@pytest.mark.parametrize("content, complaint", [
    (MALFORMED, "parameter file"), (MISTYPED, "translation_stiffness"),
    (MISSPELT, "unknown parameter 'translaton_stiffness' for node replica; did you mean 'translation_stiffness'?")])
def test_replica_refuses_a_bad_parameter_file_and_the_robot_holds(content, complaint, start_node, rclpy_context,
                                                                   tmp_path: Path) -> None:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState

    robot = start_node("sim_bridge", "robot_node", params={"scene": "free_space", "mode": "realtime"}, name="robot")
    bad_file = tmp_path / "replica.yaml"
    bad_file.write_text(content)
    replica = start_node("fic_teleop_replica", "replica_node", params_file=bad_file, name="replica")
    replica.expected_returncode = 2  # the refusal is the clean stop here (the fixture checks the rest)
    replica.process.wait(timeout=60)
    assert replica.process.returncode == 2
    fatal = [line for line in replica.output().splitlines() if "FATAL" in line]
    assert len(fatal) == 1 and "cannot start" in fatal[0] and complaint in fatal[0], replica.output()
    assert "Traceback" not in replica.output()

    node = rclpy.create_node("observer", context=rclpy_context)
    velocities: list[np.ndarray] = []
    node.create_subscription(JointState, "/joint_states", lambda m: velocities.append(np.array(m.velocity)),
                             QoSProfile(depth=1000))
    executor = SingleThreadedExecutor(context=rclpy_context)
    executor.add_node(node)
    deadline = time.monotonic() + 30
    while len(velocities) < 2000 and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.1)
    assert len(velocities) >= 500, "the robot published no joint states"
    assert robot.running()
    assert np.abs(np.array(velocities)).max() < 0.05  # held still by gravity compensation and damping [rad/s]
    assert "holding the arm" in robot.output()
