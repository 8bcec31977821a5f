"""The replica node's eyes on the graph for fic_core.replica_station's input guarding: who writes each guarded stream.

Wiring only: what a second writer means (the safe hold, named), what a command may ask and which joint-state stamps
are foreign are ReplicaStation's (fic_core.input_authority inside). This module looks the writers up in the graph
every PUBLISHER_CHECK_PERIOD_S, gives the guarded subscriptions the middleware's writer-matched event (which comes
with a second writer's first message), counts the writers of /replica/teleop_command for each command, logs the
safe hold in one error line and has the node publish /diagnostics at once (level ERROR; recorded in the bag, read
back by the launcher's exit code). The input authority's parameters are fic_core.input_authority's rows.
"""
from __future__ import annotations

import threading

from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.node import Node

from fic_core.replica_station import CHANNEL_STREAMS, ROBOT_STREAMS, SET_POINT_STREAMS, TELEOP_STREAM, ReplicaStation

PUBLISHER_CHECK_PERIOD_S = 0.5  # graph lookups are cheap; a new writer is discovered within about a second anyway

UNNAMED = "a node not yet named in discovery"
#: After a hold that could not name every writer: how long the graph is still asked for their names [s].
NAMING_WINDOW_S = 30.0


def _node_name(info) -> str:
    """A writer's node, as the graph knows it (a writer discovered before its node's name: said so)."""
    if info.node_name == "_NODE_NAME_UNKNOWN_":
        return UNNAMED
    return f"{info.node_namespace.rstrip('/')}/{info.node_name}"


class InputGuard:
    """The graph's writers of ``station``'s guarded streams, on ``node`` (module docstring)."""

    def __init__(self, node: Node, station: ReplicaStation, on_hold, lock: threading.RLock) -> None:
        self._node = node
        self._station = station
        self._lock = lock   # the node's: the station is also stepped from the robot's thread (in_process_link.py)
        self._on_hold = on_hold  # called once, when the safe hold latches (the node publishes diagnostics)
        # The names after the node's remaps (a driver profile renames /joint_states): count the writers there,
        # name them as the station knows them.
        self._streams = {node.resolve_topic_name(topic): topic
                         for topic in ROBOT_STREAMS + SET_POINT_STREAMS + CHANNEL_STREAMS}
        self._teleop_topic = node.resolve_topic_name(TELEOP_STREAM)
        # A hold whose line could not name every writer (the middleware's match, or discovery, came before the
        # node names): the stream and until when the graph is asked again, so that the writer is still named.
        self._unnamed: tuple[str, float] | None = None
        node.create_timer(PUBLISHER_CHECK_PERIOD_S, self._check_publishers)

    def teleop_writers(self) -> int:
        """How many write /replica/teleop_command now (the channel, or the master without one: one)."""
        return self._node.count_publishers(self._teleop_topic)

    def stream_events(self, topic: str) -> SubscriptionEventCallbacks:
        """For a guarded stream's subscription (ROBOT_STREAMS, SET_POINT_STREAMS, CHANNEL_STREAMS): the middleware's
        writer-matched event, which comes with a second writer's first message or within a message or two (the
        graph lookup every PUBLISHER_CHECK_PERIOD_S lets a loaded machine run the law on that writer's data for as
        long)."""
        resolved = self._node.resolve_topic_name(topic)
        return SubscriptionEventCallbacks(matched=lambda status: self._on_writers(resolved, status))

    def _on_writers(self, resolved: str, status) -> None:
        with self._lock:
            self._on_writers_locked(resolved, status)

    def _on_writers_locked(self, resolved: str, status) -> None:
        if status.current_count <= 1 or self._station.held:
            return
        self._check_publishers()  # names the writers if the graph has them already
        reason = self._station.matched(resolved, status.current_count, self._streams[resolved])
        if reason:
            self.hold(reason, resolved)

    def _writers(self, resolved: str) -> list[str]:
        return [_node_name(info) for info in self._node.get_publishers_info_by_topic(resolved)]

    def _check_publishers(self) -> None:
        with self._lock:
            self._check_publishers_locked()

    def _check_publishers_locked(self) -> None:
        if self._station.held:
            self._name_late_writers()
            return
        for resolved, topic in self._streams.items():
            writers = self._writers(resolved)
            reason = self._station.writers(resolved, writers, topic)
            if reason:
                self.hold(reason, resolved)
                return

    def _name_late_writers(self) -> None:
        """After a hold that could not name every writer: one more line once discovery has their names."""
        if self._unnamed is None:
            return
        resolved, until = self._unnamed
        writers = self._writers(resolved)
        if len(writers) > 1 and UNNAMED not in writers:
            self._node.get_logger().error(f"SAFE HOLD: the writers on {self._streams[resolved]}, now named by "
                                          f"discovery: {', '.join(sorted(writers))}")
            self._unnamed = None
        elif self._clock_s() > until:
            self._node.get_logger().error(f"SAFE HOLD: the writers on {self._streams[resolved]} were not all named "
                                          f"within {NAMING_WINDOW_S:g} s: {', '.join(sorted(writers)) or 'none left'}")
            self._unnamed = None

    def _clock_s(self) -> float:
        return self._node.get_clock().now().nanoseconds * 1e-9

    def hold(self, reason: str, resolved: str | None = None) -> None:
        """The safe hold latched (``reason``, once): one error line, /diagnostics at once. When the line could not
        name every writer of ``resolved``, the graph is asked again until it can (``_name_late_writers``)."""
        self._node.get_logger().error(
            f"SAFE HOLD: {reason}. The replica sends no more torques (no joint state or set-point can be trusted to "
            "be its owner's): the robot's own command watchdog holds the arm, until the replica is restarted "
            "(fic_core.input_authority)")
        if resolved is not None and resolved in self._streams:
            writers = self._writers(resolved)   # one graph lookup: is every writer named by now?
            if UNNAMED in reason or UNNAMED in writers or len(writers) <= 1:
                self._unnamed = (resolved, self._clock_s() + NAMING_WINDOW_S)
        self._on_hold()
