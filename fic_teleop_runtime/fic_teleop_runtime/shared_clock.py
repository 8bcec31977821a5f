"""One /clock subscription for the nodes sharing a process (node_group.py) under simulated time.

rclpy gives every node its own time source, and each subscribes to /clock: a group of two nodes took every /clock
message twice, two Python callbacks setting two clocks to the same time. In lockstep /clock comes hundreds of times a
simulated second (docs/CONVENTIONS.md, "Time"), so the second subscription was a second wake-up of the
process and a second delivery of the simulation's publisher at every one. Here the first member's time source sets
the clocks of the members whose /clock is the same topic, and their own subscriptions are dropped: each node still
reads its own clock, set to the same time by the same message.

rclpy has no public call for this: ``Node._time_source`` and ``TimeSource.detach_node`` / ``attach_clock`` are what
rclpy's own Node uses to wire its clock (rclpy 7.1, ROS 2 Jazzy).
"""
from __future__ import annotations

from collections.abc import Sequence

from rclpy.node import Node


def _clock_topic(node: Node) -> str | None:
    """The topic the node's time source reads /clock from (its remaps applied); None: it follows no /clock."""
    subscription = getattr(node._time_source, "_clock_sub", None)
    return subscription.topic_name if subscription is not None else None


def share_clock_subscription(nodes: Sequence[Node]) -> int:
    """Let the first node of each /clock topic drive the clocks of the others (module docstring); returns how many
    subscriptions were dropped."""
    drivers: dict[str, Node] = {}
    dropped = 0
    for node in nodes:
        topic = _clock_topic(node)
        if topic is None:
            continue
        driver = drivers.setdefault(topic, node)
        if driver is node:
            continue
        node._time_source.detach_node()   # destroys this node's /clock subscription; its clock keeps ROS time on
        driver._time_source.attach_clock(node.get_clock())   # set by the driver's messages from now on
        dropped += 1
    return dropped
