"""The master and planner nodes as real processes over DDS (the installed executables, config/*.yaml).

Master: a displaced handle gets a restoring force (Eq. 3's FIC(-x_M)) plus K_H*F_R; K_H = 5 is clamped to 1
with a log line (at start and at run time), NaN is refused; joystick buttons toggle the mode and step K_H; the
teleoperation command carries x_M and x_d'. Planner: x_d'' moves from its start to a fixed point without
overshoot and tracks the paper's circle.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")
fic_teleop_msgs = pytest.importorskip("fic_teleop_msgs.msg")
from conftest import CONFIG  # noqa: E402
from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped  # noqa: E402
from master_peer import JOY_QOS, QOS, STARTUP_TIMEOUT, Peer  # noqa: E402
from sensor_msgs.msg import Joy  # noqa: E402

from fic_core.profile import ForceProfile  # noqa: E402

pytestmark = pytest.mark.nodes


def test_master_node(start_node, rclpy_context) -> None:
    master = start_node("fic_teleop_master", "master_node", params_file=CONFIG / "master.yaml",
                        params={"haptic_gain": 5.0, "feedback_timeout": 0.3})
    assert master.wait_for_output("master up", STARTUP_TIMEOUT), master.output()
    assert "haptic_gain 5.0 from parameter clamped to 1.0" in master.output()
    peer = Peer(rclpy_context, "master_peer")
    try:
        pose_publisher = peer.node.create_publisher(PoseStamped, "/haptic/pose", QOS)
        twist_publisher = peer.node.create_publisher(TwistStamped, "/haptic/twist", QOS)
        feedback_publisher = peer.node.create_publisher(WrenchStamped, "/master/feedback_wrench", QOS)
        joy_publisher = peer.node.create_publisher(Joy, "/operator/joy", JOY_QOS)
        peer.subscribe(WrenchStamped, "/haptic/wrench_command")
        peer.subscribe(fic_teleop_msgs.TeleoperationCommand, "/master/teleop_command")
        handle = {"position": (0.015, -0.01, 0.0), "feedback": None}

        def publish_inputs() -> None:
            pose = PoseStamped()
            pose.header.frame_id = "haptic_base"
            pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = handle["position"]
            pose.pose.orientation.w = 1.0
            pose_publisher.publish(pose)
            twist_publisher.publish(TwistStamped())  # the handle is held still
            if handle["feedback"] is not None:
                wrench = WrenchStamped()
                wrench.wrench.force.x, wrench.wrench.force.y, wrench.wrench.force.z = handle["feedback"]
                feedback_publisher.publish(wrench)

        wrenches = peer.received["/haptic/wrench_command"]
        commands = peer.received["/master/teleop_command"]
        assert peer.spin_until(lambda: len(wrenches) > 20 and len(commands) > 10, 30.0, 0.01, publish_inputs)
        # Restoring force: FIC(-x_M) of the handle's profile (config/master.yaml), F_R stale -> 0 (warned once).
        profile = ForceProfile(100.0, 0.04, 0.5, 6.0)
        expected = -profile.force(np.array(handle["position"]))
        force = wrenches[-1].wrench.force
        np.testing.assert_allclose([force.x, force.y, force.z], expected, atol=1e-9)
        assert force.x < 0 < force.y
        assert "/master/feedback_wrench is stale" in master.output()
        command = commands[-1]
        assert command.mode == 0 and command.haptic_gain == 1.0
        np.testing.assert_allclose([command.desired_offset.x, command.desired_offset.y], handle["position"][:2])
        np.testing.assert_allclose([command.handle_position.x, command.handle_position.y], handle["position"][:2])
        assert command.header.stamp.sec > 0

        # With F_R fresh, the clamped K_H = 1 renders all of it on the handle.
        handle["feedback"] = (0.0, 0.0, 3.0)
        wrenches.clear()
        assert peer.spin_until(lambda: len(wrenches) > 5 and abs(wrenches[-1].wrench.force.z - 3.0) < 1e-9,
                               10.0, 0.01, publish_inputs)

        # Run-time K_H: 5 clamped to 1 (logged), NaN refused with a reason.
        assert peer.set_parameter("master", "haptic_gain", 0.4) == (True, "")
        assert peer.set_parameter("master", "haptic_gain", 5.0)[0]
        assert peer.get_parameter("master", "haptic_gain").double_value == 1.0
        assert master.wait_for_output("haptic_gain 5.0 is outside [0, 1]: clamped to 1.0", 5.0)
        successful, reason = peer.set_parameter("master", "haptic_gain", math.nan)
        assert not successful and reason
        assert peer.get_parameter("master", "haptic_gain").double_value == 1.0
        successful, reason = peer.set_parameter("master", "stiffness", -3.0)
        assert not successful and reason

        # Buttons (rising edges): 2 lowers K_H by 0.1, 0 toggles the mode, without a jump of x_d'.
        def press(button: int) -> None:
            buttons = [0, 0, 0]
            buttons[button] = 1
            joy_publisher.publish(Joy(buttons=buttons))
            peer.spin_for(0.05, 0.01, publish_inputs)
            joy_publisher.publish(Joy(buttons=[0, 0, 0]))

        offset_before = commands[-1].desired_offset
        press(2)
        press(0)
        commands.clear()
        assert peer.spin_until(lambda: len(commands) > 5 and commands[-1].mode == 1
                               and abs(commands[-1].haptic_gain - 0.9) < 1e-9, 10.0, 0.01, publish_inputs)
        # Velocity mode from where offset mode left x_d' (k_v = 2, dead-band 5 mm: drift well below 1 cm here).
        assert abs(commands[0].desired_offset.x - offset_before.x) < 0.01
        assert commands[-1].desired_offset.x > commands[0].desired_offset.x  # integrating the held displacement

        # NaN pose: refused with a log line, the last good pose is held.
        handle["position"] = (math.nan, 0.0, 0.0)
        peer.spin_for(0.3, 0.01, publish_inputs)
        assert "refused /haptic/pose with non-finite values" in master.output()
        assert all(math.isfinite(w.wrench.force.x) for w in wrenches)
    finally:
        peer.close()
    assert master.stop() == 0, master.output()


def test_planner_node_fixed_point_and_circle(start_node, rclpy_context) -> None:
    start, target = (0.30, 0.0, 0.50), (0.45, 0.05, 0.35)
    planner = start_node("fic_teleop_planner", "planner_node", params_file=CONFIG / "planner.yaml",
                         params={"trajectory": "fixed", "fixed_point": list(target), "start_position": list(start)})
    assert planner.wait_for_output("planner up", STARTUP_TIMEOUT), planner.output()
    peer = Peer(rclpy_context, "planner_peer")
    try:
        peer.subscribe(PoseStamped, "/planner/desired_pose")
        poses = peer.received["/planner/desired_pose"]
        position = lambda message: np.array([message.pose.position.x, message.pose.position.y,  # noqa: E731
                                             message.pose.position.z])
        assert peer.spin_until(lambda: len(poses) > 0 and np.linalg.norm(position(poses[-1]) - target) < 1e-3, 30.0)
        assert poses[-1].header.frame_id == "panda_link0"
        orientation = poses[-1].pose.orientation
        assert (orientation.x, orientation.y, orientation.z, orientation.w) == (1.0, 0.0, 0.0, 0.0)
        path = np.array([position(p) for p in poses])
        direction = (np.array(target) - start) / np.linalg.norm(np.subtract(target, start))
        assert np.max((path - target) @ direction) <= 0.01 * np.linalg.norm(np.subtract(target, start))

        # Switch to the paper's circle at run time: the planner moves there and tracks it.
        client_ok = peer.set_parameter("planner", "circle_diameter", 0.2)
        assert client_ok == (True, "")
        successful, reason = peer.set_parameter("planner", "natural_frequency", -1.0)
        assert not successful and reason
        assert peer.set_parameter("planner", "trajectory", "circle") == (True, "")
        poses.clear()
        peer.spin_for(8.0)
        centre = np.array([0.45, 0.0, 0.35])
        late = np.array([position(p) for p in poses[len(poses) // 2:]])
        radii = np.linalg.norm(late[:, :2] - centre[:2], axis=1)
        assert np.all(np.abs(radii - 0.10) < 0.01) and np.all(np.abs(late[:, 2] - 0.35) < 1e-3)
    finally:
        peer.close()
    assert planner.stop() == 0, planner.output()
