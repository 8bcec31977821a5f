"""The haptic device node's shape-sorting operator source (E2): the wiring of what it sees and feels.

The node is built in the test's process and its callbacks called directly (no DDS traffic): the delayed video's
two halves make one frame with every piece, a frame without every piece is refused with one line, the operator
feels the force the motors render, and its mode switches reach the button queue. The graph run of the operator is
test_shape_sorting_operator_graph.py."""
from __future__ import annotations

import time

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")
from builtin_interfaces.msg import Time  # noqa: E402
from geometry_msgs.msg import Pose, PoseArray, PoseStamped  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

from fic_core.errors import FicInputError  # noqa: E402
from sim_bridge.device.haptic_device_node import HapticDeviceNode  # noqa: E402
from sim_bridge.device.virtual_operator import BUTTON_TOGGLE_MODE  # noqa: E402
from sim_bridge.robot.scenes import SHAPE_SORTING_PIECES  # noqa: E402

pytestmark = pytest.mark.nodes

HIGH_TCP = np.array([0.45, -0.2, 0.45])   # far above and away from every piece: the operator's first move travels


def _node(context, **parameters) -> HapticDeviceNode:
    values = {"operator_source": "shape_sorting", "scene": "shape_sorting", **parameters}
    return HapticDeviceNode(context=context,
                            parameter_overrides=[Parameter(key, value=value) for key, value in values.items()])


def _stamp(seconds: float) -> Time:
    return Time(sec=int(seconds), nanosec=int(round((seconds % 1.0) * 1e9)))


def _send_frame(node: HapticDeviceNode, stamp: float, tcp: np.ndarray, pieces: np.ndarray) -> None:
    """The two halves of one capture, the objects first (the channel delivers them apart)."""
    objects = PoseArray()
    objects.header.stamp = _stamp(stamp)
    for piece in pieces:
        pose = Pose()
        pose.position.x, pose.position.y, pose.position.z = (float(v) for v in piece)
        objects.poses.append(pose)
    node._on_video_objects(objects)
    message = PoseStamped()
    message.header.stamp = _stamp(stamp)
    message.pose.position.x, message.pose.position.y, message.pose.position.z = (float(v) for v in tcp)
    node._on_video_tcp(message)


def _start_pieces() -> np.ndarray:
    return np.array([piece.start_position for piece in SHAPE_SORTING_PIECES], dtype=float)


def test_the_video_halves_make_one_frame_with_every_piece(rclpy_context) -> None:
    node = _node(rclpy_context)
    pieces = _start_pieces()
    _send_frame(node, 12.5, HIGH_TCP, pieces)
    (arrival, frame), = node.sorter._frames
    assert frame.stamp == pytest.approx(12.5)
    np.testing.assert_allclose(frame.tcp, HIGH_TCP)
    np.testing.assert_allclose(frame.pieces, pieces)   # in the scene's order, as /sim/object_poses holds them
    assert arrival == pytest.approx(node._now(), abs=1.0)


def test_a_frame_without_every_piece_is_refused_and_the_node_goes_on(rclpy_context, caplog) -> None:
    node = _node(rclpy_context)
    _send_frame(node, 3.0, HIGH_TCP, _start_pieces()[:1])   # the superimposition scene's one obstacle
    assert not node.sorter._frames
    _send_frame(node, 3.1, HIGH_TCP, _start_pieces())
    assert len(node.sorter._frames) == 1
    node._tick()                                            # still ticks


def test_the_operator_feels_the_force_the_motors_render(rclpy_context) -> None:
    node = _node(rclpy_context)
    node.station.command(np.array([0.0, 0.0, 50.0]), node._now())   # beyond the 20 N saturation
    node._tick()
    # The handle has barely moved in one tick: the learnt centring spring is about zero, so the felt contact is the
    # rendered force, saturated as the motors saturate it.
    np.testing.assert_allclose(node.sorter.felt_contact, node.device.saturate(np.array([0.0, 0.0, 50.0])),
                               atol=0.05)
    assert np.linalg.norm(node.sorter.felt_contact) == pytest.approx(node.device.parameters.max_force, abs=0.05)


def test_its_first_travel_switches_the_master_to_velocity_mode_with_a_button(rclpy_context) -> None:
    node = _node(rclpy_context, reaction_time=0.0)
    pieces = _start_pieces()
    deadline = time.monotonic() + 5.0
    while BUTTON_TOGGLE_MODE not in node.station.buttons and time.monotonic() < deadline:
        _send_frame(node, node._now(), HIGH_TCP, pieces)      # the robot seen at rest
        node._tick()
        time.sleep(0.01)
    assert list(node.station.buttons) == [BUTTON_TOGGLE_MODE]
    assert any(label.endswith(":reach") for label, _, _ in node.sorter.moves_started)


def test_it_drives_the_shape_sorting_scene_only(rclpy_context) -> None:
    with pytest.raises(FicInputError, match="shape_sorting scene only"):
        _node(rclpy_context, scene="superimposition")
