"""The command relay (fic_teleop_replica command_relay_node) carries the replica's state stamp on.

The replica names the joint state each torque was computed on in the command's layout (fic_core.command_stamp); the
robot refuses a torque computed on too old a state. Behind the relay (the franka_ros2 profile) the label must reach
the robot: a relay that sent the data alone would make every torque, however stale, look unstamped and be applied.
"""
from __future__ import annotations

import time

import pytest
from conftest import CONFIG
from driver_peer import Peer, qos

rclpy = pytest.importorskip("rclpy")

from fic_core import command_stamp  # noqa: E402


def test_the_relay_forwards_the_commands_state_stamp(start_node, ros_env, rclpy_context) -> None:
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension, MultiArrayLayout

    relay = start_node("fic_teleop_replica", "command_relay_node", params_file=CONFIG / "command_relay.yaml")
    assert relay.wait_for_output("command relay up", timeout=60.0), relay.output()
    peer = Peer(rclpy_context, "test_relay_stamp")
    received: list = []
    peer.node.create_subscription(Float64MultiArray, "/effort_controller/commands", received.append, qos(True, 100))
    publisher = peer.node.create_publisher(Float64MultiArray, "/replica/effort_command", qos(True, 10))

    def send(stamp: int) -> None:
        publisher.publish(Float64MultiArray(
            layout=MultiArrayLayout(dim=[MultiArrayDimension(label=command_stamp.label(stamp), size=7, stride=7)]),
            data=[0.1 * k for k in range(7)]))

    # The path open end to end before the stamps are sent: a command forwarded to this reader (a volatile writer
    # sends only to the readers it has matched; the graph's counts and this side's matches came before the relay's
    # writer had matched this reader, losing the first forward in 2 of 9 runs).
    warm_up = 900_000_000
    deadline = time.monotonic() + 30.0
    while not received and time.monotonic() < deadline:
        send(warm_up)
        peer.spin(0.05)
    assert received, relay.output()
    received.clear()
    stamps = [1_000_000_000 + 1_000_000 * k for k in range(20)]
    for stamp in stamps:
        send(stamp)
        peer.spin(0.002)   # 2 ms apart: inside the relay's 50 ms timeout, no ramp comes between
    assert peer.spin_until(lambda: len(received) >= len(stamps), 10.0), (len(received), relay.output())
    # a late warm-up forward, or the relay's ramp after the warm-up (no label), may come first: every one of the
    # stamps must come labelled, in order
    labelled = [m for m in received if m.layout.dim and command_stamp.stamp_ns(m.layout.dim[0].label) != warm_up]
    forwarded = [command_stamp.stamp_ns(m.layout.dim[0].label) for m in labelled]
    assert forwarded[:len(stamps)] == stamps, forwarded
    received = labelled
    assert list(received[0].data) == pytest.approx([0.1 * k for k in range(7)])
