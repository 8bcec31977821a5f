"""The replica node's input guard names a second writer that discovery had not named when the safe hold latched:
one more line once the graph has the name (fic_teleop_replica/input_guard.py), checked on a stand-in node and
station (the graph run is test/nodes/test_set_point_guard.py)."""
from __future__ import annotations

import threading
from types import SimpleNamespace

import pytest

from fic_teleop_replica.input_guard import NAMING_WINDOW_S, InputGuard

TOPIC = "/planner/desired_pose"


class _Node:
    def __init__(self) -> None:
        self.lines: list[str] = []
        self.writers: list[tuple[str, str]] = []
        self.now_ns = 0
        self.timer = None

    def resolve_topic_name(self, topic: str) -> str:
        return topic

    def create_timer(self, period: float, callback) -> None:
        self.timer = callback

    def get_logger(self):
        return SimpleNamespace(error=self.lines.append)

    def get_clock(self):
        return SimpleNamespace(now=lambda: SimpleNamespace(nanoseconds=self.now_ns))

    def get_publishers_info_by_topic(self, topic: str):
        return [SimpleNamespace(node_name=name, node_namespace=namespace) for name, namespace in self.writers
                if topic == TOPIC]

    def count_publishers(self, topic: str) -> int:
        return len(self.writers)


class _Station:
    """Holds on a second writer of TOPIC, naming them as they were given (as ReplicaStation does)."""

    def __init__(self) -> None:
        self.held = False

    def writers(self, resolved: str, writers: list[str], topic: str) -> str | None:
        if topic == TOPIC and len(writers) > 1 and not self.held:
            self.held = True
            return f"{len(writers)} publishers on {topic} ({', '.join(writers)}); one is the planner's"
        return None


@pytest.fixture(autouse=True)
def _one_guarded_stream(monkeypatch) -> None:
    import fic_teleop_replica.input_guard as module

    monkeypatch.setattr(module, "ROBOT_STREAMS", ())
    monkeypatch.setattr(module, "SET_POINT_STREAMS", (TOPIC,))


def _guard(node: _Node) -> InputGuard:
    return InputGuard(node, _Station(), on_hold=lambda: None, lock=threading.RLock())


def test_a_writer_unnamed_at_the_hold_is_named_once_discovery_has_it() -> None:
    node = _Node()
    _guard(node)
    node.writers = [("planner", "/"), ("_NODE_NAME_UNKNOWN_", "_NODE_NAMESPACE_UNKNOWN_")]
    node.timer()
    assert len(node.lines) == 1 and "a node not yet named in discovery" in node.lines[0]
    node.timer()   # still unnamed: nothing more said
    assert len(node.lines) == 1
    node.writers[1] = ("outside_client", "/")
    node.timer()
    assert len(node.lines) == 2 and node.lines[1] == (f"SAFE HOLD: the writers on {TOPIC}, now named by discovery: "
                                                      "/outside_client, /planner")
    node.timer()   # said once
    assert len(node.lines) == 2


def test_a_writer_never_named_is_said_so_after_the_window_and_a_named_hold_needs_no_second_line() -> None:
    node = _Node()
    _guard(node)
    node.writers = [("planner", "/"), ("_NODE_NAME_UNKNOWN_", "_NODE_NAMESPACE_UNKNOWN_")]
    node.timer()
    node.now_ns = int((NAMING_WINDOW_S + 1.0) * 1e9)
    node.timer()
    assert len(node.lines) == 2 and "were not all named within" in node.lines[1]

    named = _Node()
    _guard(named)
    named.writers = [("planner", "/"), ("outside_client", "/")]
    named.timer()
    named.timer()
    assert len(named.lines) == 1 and "/outside_client" in named.lines[0]
