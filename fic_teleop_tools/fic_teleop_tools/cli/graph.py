"""A short-lived rclpy node that looks at the running graph (topics, nodes) for one command."""
from __future__ import annotations

import contextlib
import time
from typing import Callable, Iterator

import rclpy
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from fic_teleop_tools.cli.errors import CommandError


@contextlib.contextmanager
def graph_node(name: str = "fic_cli") -> Iterator[Node]:
    """A hidden node (its name starts with an underscore, as ros2cli's daemon-less nodes do) for one command."""
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node(f"_{name}", start_parameter_services=False)
    try:
        yield node
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def settle(node: Node, read: Callable[[], object], timeout: float, quiet: float = 2.0):
    """Spin until `read()` has not changed for `quiet` seconds (discovery has settled) or `timeout` passed.

    DDS discovery has no end marker, so a listing waits until nothing new has appeared for a moment."""
    deadline = time.monotonic() + timeout
    last, since = read(), time.monotonic()
    while time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
        current = read()
        if current != last:
            last, since = current, time.monotonic()
        elif current and time.monotonic() - since >= quiet:
            break
    return last


def topic_type(node: Node, topic: str, timeout: float) -> str:
    """The one type `topic` is published with; waits up to `timeout` s for it to appear."""
    deadline = time.monotonic() + timeout
    while True:
        types = dict(node.get_topic_names_and_types()).get(topic)
        if types:
            break
        if time.monotonic() >= deadline:
            raise CommandError(f"topic {topic} is not in the graph (waited {timeout:g} s; `scripts/fic topic list`)")
        rclpy.spin_once(node, timeout_sec=0.05)
    if len(types) != 1:
        raise CommandError(f"topic {topic} is published with {len(types)} types: {', '.join(types)}")
    return types[0]


def node_names(node: Node) -> list[str]:
    own = node.get_fully_qualified_name()
    return sorted(name for name in
                  (f"{ns.rstrip('/')}/{n}" for n, ns in node.get_node_names_and_namespaces())
                  if name != own and not name.split("/")[-1].startswith("_"))


def fully_qualified(node_name: str) -> str:
    return node_name if node_name.startswith("/") else f"/{node_name}"
