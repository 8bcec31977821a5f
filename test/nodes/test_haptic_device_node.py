"""The haptic device node as a real process over DDS: the force command moves the handle; NaN is refused;
a stale command renders zero force; the scripted operator presses its buttons on /operator/joy."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

rclpy = pytest.importorskip("rclpy")
from conftest import assert_stopped_clean  # noqa: E402
from geometry_msgs.msg import PoseStamped, WrenchStamped  # noqa: E402
from rclpy.experimental import EventsExecutor  # noqa: E402
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402

pytestmark = pytest.mark.nodes

REPO = Path(__file__).resolve().parents[2]
QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=20)


def test_force_command_moves_the_handle_nan_is_refused_and_stale_commands_go_limp(tmp_path, ros_env):
    env = dict(os.environ, ROS_DOMAIN_ID=ros_env["ROS_DOMAIN_ID"], ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               ROS_LOG_DIR=str(tmp_path / "ros_log"), PYTHONUNBUFFERED="1", RCUTILS_COLORIZED_OUTPUT="0")
    saved = {key: os.environ.get(key) for key in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOG_DIR")}
    os.environ.update({key: env[key] for key in saved})
    log_path = tmp_path / "haptic.log"
    with open(log_path, "wb") as log:
        device = subprocess.Popen([sys.executable, "-m", "sim_bridge.device.haptic_device_node", "--ros-args",
                                   "--params-file", str(REPO / "config" / "haptic_device.yaml"),
                                   "-p", "operator_source:=none"], env=env, stdout=log, stderr=subprocess.STDOUT)
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("haptic_probe", context=context)
    executor = EventsExecutor(context=context)
    executor.add_node(node)
    poses: list[float] = []
    node.create_subscription(PoseStamped, "/haptic/pose", lambda m: poses.append(m.pose.position.x), QOS)
    command = node.create_publisher(WrenchStamped, "/haptic/wrench_command", QOS)
    force = {"x": 0.0}

    def send() -> None:
        message = WrenchStamped()
        message.header.stamp = node.get_clock().now().to_msg()
        message.header.frame_id = "haptic_base"
        message.wrench.force.x = force["x"]
        command.publish(message)

    sending = node.create_timer(0.002, send)

    def spin_for(seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.01)

    try:
        deadline = time.monotonic() + 30.0
        while not poses and time.monotonic() < deadline:
            assert device.poll() is None, log_path.read_text()
            spin_for(0.1)
        assert poses, "no /haptic/pose"
        spin_for(0.5)
        rest = poses[-1]
        assert abs(rest) < 1e-9                          # no force, no hand: the handle stays put
        force["x"] = 0.5                                 # 0.5 N on 0.5 kg: 1 m/s^2
        spin_for(0.2)
        moved = poses[-1]
        assert moved > 0.005                             # ~0.5 * 1 * 0.2^2 = 0.02 m, less damping and latency
        force["x"] = float("nan")                        # refused: the last good command (0.5 N) is not kept
        spin_for(0.15)                                   # ...beyond command_timeout (0.1 s): zero force
        sending.cancel()
        spin_for(0.1)
        samples = []
        for _ in range(3):
            start = poses[-1]
            spin_for(0.15)
            samples.append((poses[-1] - start) / 0.15)
        # Zero force: the handle coasts and the damping slows it (a kept 0.5 N would keep it accelerating).
        assert samples[0] > samples[1] > samples[2] >= 0.0, samples
        assert poses[-1] < 0.095                         # and it never reached the wall
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
        device.send_signal(signal.SIGINT)
        code = device.wait(timeout=10)
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
    output = log_path.read_text()
    assert_stopped_clean(code, output, "haptic_device_node")
    assert "refused /haptic/wrench_command with a non-finite force" in output
    assert output.count("force command stale") == 1
    assert "Traceback" not in output
