"""The operator's tools on a running master node over DDS (docs/TOOLS.md, "The operator's tools"): each set as a
parameter while the node runs, its effect read on the node's own topics (/master/teleop_command,
/haptic/wrench_command, /master/operator_tools): the clutch holds x_d' and re-anchors on release, the force scale
is refused past the loop-gain bound, a plane fixture pulls the handle toward it, homing drives the handle home and
engages it; a misspelt or out-of-range parameter is refused in one line."""
from __future__ import annotations

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")
fic_teleop_msgs = pytest.importorskip("fic_teleop_msgs.msg")
from conftest import CONFIG  # noqa: E402
from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped  # noqa: E402
from master_peer import QOS, STARTUP_TIMEOUT, Peer  # noqa: E402

pytestmark = pytest.mark.nodes
OperatorTools = fic_teleop_msgs.OperatorTools


def xyz(point) -> np.ndarray:
    return np.array([point.x, point.y, point.z])


def test_operator_tools_set_live(start_node, rclpy_context) -> None:
    master = start_node("fic_teleop_master", "master_node", params_file=CONFIG / "master.yaml",
                        params={"haptic_gain": 0.5, "feedback_timeout": 0.3, "tools_rate": 20.0})
    assert master.wait_for_output("master up", STARTUP_TIMEOUT), master.output()
    peer = Peer(rclpy_context, "tools_peer")
    try:
        pose_publisher = peer.node.create_publisher(PoseStamped, "/haptic/pose", QOS)
        twist_publisher = peer.node.create_publisher(TwistStamped, "/haptic/twist", QOS)
        feedback_publisher = peer.node.create_publisher(WrenchStamped, "/master/feedback_wrench", QOS)
        for message_type, topic in ((WrenchStamped, "/haptic/wrench_command"),
                                    (fic_teleop_msgs.TeleoperationCommand, "/master/teleop_command"),
                                    (OperatorTools, "/master/operator_tools")):
            peer.subscribe(message_type, topic)
        wrenches = peer.received["/haptic/wrench_command"]
        commands = peer.received["/master/teleop_command"]
        tools = peer.received["/master/operator_tools"]
        handle = {"position": (0.01, 0.0, 0.0)}

        def publish_inputs() -> None:
            pose = PoseStamped()
            pose.header.frame_id = "haptic_base"
            pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = handle["position"]
            pose.pose.orientation.w = 1.0
            pose_publisher.publish(pose)
            twist_publisher.publish(TwistStamped())  # the handle is held still wherever it is
            wrench = WrenchStamped()
            wrench.wrench.force.z = 3.0                # F_R, fresh
            feedback_publisher.publish(wrench)

        def settle(condition, timeout: float = 10.0) -> bool:
            """Spin with the inputs going until ``condition`` holds on messages that came after this call."""
            for received in (wrenches, commands, tools):
                received.clear()
            return peer.spin_until(lambda: len(wrenches) > 3 and len(commands) > 3 and condition(), timeout,
                                   0.01, publish_inputs)

        def offset() -> np.ndarray:
            return xyz(commands[-1].desired_offset)

        assert settle(lambda: tools and abs(offset()[0] - 0.01) < 1e-9, 30.0), master.output()
        assert tools[-1].engagement == OperatorTools.ENGAGEMENT_ENGAGED and tools[-1].loop_gain == 0.5

        # The clutch: the handle moves, x_d' holds still, F_R is not rendered; released, x_d' continues from there.
        assert peer.set_parameter("master", "clutch", True) == (True, "")
        handle["position"] = (-0.02, 0.0, 0.0)
        assert settle(lambda: tools and tools[-1].engagement == OperatorTools.ENGAGEMENT_CLUTCHED
                      and xyz(commands[-1].handle_position)[0] == -0.02)
        np.testing.assert_allclose(offset(), [0.01, 0.0, 0.0])
        assert abs(wrenches[-1].wrench.force.z) < 1e-9 and wrenches[-1].wrench.force.x > 0   # the FIC alone
        assert peer.set_parameter("master", "clutch", False) == (True, "")
        assert settle(lambda: tools and tools[-1].engagement == OperatorTools.ENGAGEMENT_ENGAGED)
        np.testing.assert_allclose(offset(), [0.01, 0.0, 0.0])                 # no jump
        handle["position"] = (0.0, 0.0, 0.0)
        assert settle(lambda: abs(offset()[0] - 0.03) < 1e-9)                   # 2 cm since the release
        assert abs(wrenches[-1].wrench.force.z - 1.5) < 1e-9                    # K_H F_R again

        # The force scale, live, inside the loop-gain bound; past it, refused in one line and nothing changes.
        assert peer.set_parameter("master", "force_scale", 2.0) == (True, "")
        assert settle(lambda: abs(wrenches[-1].wrench.force.z - 3.0) < 1e-9)   # k_F K_H F_R = 2 x 0.5 x 3
        successful, reason = peer.set_parameter("master", "force_scale", 2.5)
        assert not successful and "above the loop-gain bound 1" in reason and "\n" not in reason
        assert not peer.set_parameter("master", "workspace_scale", 1.5)[0]
        assert peer.get_parameter("master", "force_scale").double_value == 2.0
        assert master.wait_for_output("refused: force_scale x workspace_scale x haptic_gain = 2.5 x 1 x 0.5", 5.0)
        assert peer.set_parameter("master", "force_scale", 1.0) == (True, "")

        # A plane fixture through x_d' = 0 with its normal along z: the handle 5 mm up is pulled down.
        assert peer.set_parameter("master", "guidance_fixture", "plane") == (True, "")
        handle["position"] = (0.0, 0.0, 0.005)
        assert settle(lambda: tools and tools[-1].fixture == OperatorTools.FIXTURE_PLANE
                      and abs(tools[-1].guidance_force.z + 0.5) < 1e-9)        # 100 N/m x 5 mm
        assert abs(tools[-1].fixture_goal.z) < 1e-12 and abs(offset()[2]) < 1e-9   # the goal sent is on the plane
        assert wrenches[-1].wrench.force.z < 1.5 - 0.5 + 1e-9                   # K_H F_R - guidance - FIC
        successful, reason = peer.set_parameter("master", "guidance_direction", [0.0, 0.0, 0.0])
        assert not successful and "guidance_direction must not be zero" in reason
        assert peer.set_parameter("master", "guidance_fixture", "none") == (True, "")

        # Homing: the handle 4 cm out is driven in at 0.05 m/s at most (10 N s/m x 0.05 m/s = 0.5 N while it is
        # held still), x_d' held; once it is home the master engages it and `homing` reads false again.
        handle["position"] = (0.04, 0.0, 0.0)
        assert settle(lambda: abs(offset()[0] - 0.07) < 1e-9)
        assert peer.set_parameter("master", "homing", True) == (True, "")
        assert settle(lambda: tools and tools[-1].engagement == OperatorTools.ENGAGEMENT_HOMING
                      and abs(wrenches[-1].wrench.force.x + 0.5) < 1e-9)
        np.testing.assert_allclose(offset(), [0.07, 0.0, 0.0])
        assert peer.get_parameter("master", "homing").bool_value
        handle["position"] = (0.001, 0.0, 0.0)
        assert settle(lambda: tools and tools[-1].engagement == OperatorTools.ENGAGEMENT_ENGAGED)
        assert master.wait_for_output("handle homed", 5.0)
        assert peer.spin_until(lambda: not peer.get_parameter("master", "homing").bool_value, 5.0)
        np.testing.assert_allclose(offset(), [0.07, 0.0, 0.0])                 # engaged without a jump

        # A misspelt name and a value outside the declared range: one refusal each.
        successful, reason = peer.set_parameter("master", "force_scal", 1.0)
        assert not successful and "'force_scal'; did you mean 'force_scale'?" in reason
        successful, reason = peer.set_parameter("master", "homing_speed", 5.0)
        assert not successful and reason
    finally:
        peer.close()
    assert master.stop() == 0, master.output()
