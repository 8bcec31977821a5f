"""A malformed, mistyped or misspelt parameter file: the replica refuses to start with one clear log line (exit 2,
the launcher's "refused before anything started"), and the robot, left without commands, holds the arm still (its
watchdog) instead of letting it fall. The hardware profiles' fd adapter and command relay refuse a misspelt or
out-of-range parameter the same way."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from conftest import CONFIG

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


@pytest.mark.parametrize("package, executable, params_file, given, complaint", [
    ("fic_teleop_master", "fd_adapter_node", "profiles/forcedimension/fd_adapter.yaml", {"max_forse": 10.0},
     "unknown parameter 'max_forse' for node fd_adapter; did you mean 'max_force'?"),
    ("fic_teleop_master", "fd_adapter_node", "profiles/forcedimension/fd_adapter.yaml", {"max_force": 200.0},
     "max_force out of range"),
    ("fic_teleop_replica", "command_relay_node", "command_relay.yaml", {"timout": 0.1},
     "unknown parameter 'timout' for node command_relay; did you mean 'timeout'?"),
    ("fic_teleop_replica", "command_relay_node", "command_relay.yaml", {"ramp_time": 20.0},
     "ramp_time out of range")])
def test_the_hardware_nodes_refuse_a_bad_parameter_in_one_line(package, executable, params_file, given, complaint,
                                                               start_node) -> None:
    node = start_node(package, executable, params_file=CONFIG / params_file, params=given)
    node.expected_returncode = 2
    node.process.wait(timeout=60)
    assert node.process.returncode == 2
    fatal = [line for line in node.output().splitlines() if "FATAL" in line]
    assert len(fatal) == 1 and "cannot start" in fatal[0] and complaint in fatal[0], node.output()
    assert "Traceback" not in node.output()
