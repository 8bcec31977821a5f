"""The replica node's hook to fic_core.input_authority: its parameters, its log lines and its diagnostics.

Wiring only: the checks themselves are fic_core's (CommandAuthority, RobotStreamGuard); the replica loop
(fic_core.replica_loop) puts each teleoperation command through the authority. The replica node asks
``admits_teleop_command`` before each command (the safe hold, one writer on the topic), logs the loop's verdict
with ``report``, calls ``joint_state_usable`` for each joint state (and gives its subscription
``joint_state_events``), and publishes
``diagnostic_values`` with its /diagnostics (recorded in the bag, read back by the launcher's exit code). A safe
hold is said in one error line and at once on /diagnostics (level ERROR).
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.node import Node

from fic_core.input_authority import CommandAuthority, CommandVerdict, RobotStreamGuard
from fic_teleop_runtime.parameters import number

LOG_THROTTLE_S = 2.0
# Robot-side streams that must have exactly one writer: the robot's driver, and this node.
ROBOT_STREAMS = ("/joint_states", "/effort_controller/commands")
# Set-point streams the law acts on that must have at most one writer: the planner's x_d'' and its acceleration
# (none when no planner runs). A second one is a safe hold, as on the robot streams: the poses of two writers cannot
# be told apart, and flipping between them moves x_d'' (an outside client's 0.3 m away moved a resting hand 0.34 m).
SET_POINT_STREAMS = ("/planner/desired_pose", "/planner/desired_accel")
TELEOP_TOPIC = "/replica/teleop_command"
PUBLISHER_CHECK_PERIOD_S = 0.5  # graph lookups are cheap; a new writer is discovered within about a second anyway

#: What an outside input may ask of the arm (config/replica.yaml holds the values).
AUTHORITY_PARAMETERS = (
    number("offset_workspace", 0.01, 2.0, "x_d' is clamped to +- this on each axis, about the start pose [m] "
                                          "(fic_core.input_authority)"),
    number("max_offset_speed", 0.01, 10.0, "x_d' moves toward a teleoperation command no faster than this, on "
                                           "this node's clock [m/s]"),
    number("max_offset_burst", 0.0, 1.0, "x_d' may move this far at once, for bursts of delayed commands [m]"),
    number("command_future_tolerance", 0.0, 10.0, "commands and joint states stamped further ahead of this node's "
                                                  "clock are refused [s]"),
    number("max_command_age", 0.05, 600.0, "teleoperation commands stamped longer ago are refused [s] (the "
                                           "channel's delay must fit inside it; the launcher raises it with "
                                           "--delay)"),
)


def _node_name(info) -> str:
    """A writer's node, as the graph knows it (a writer discovered before its node's name: said so)."""
    if info.node_name == "_NODE_NAME_UNKNOWN_":
        return "a node not yet named in discovery"
    return f"{info.node_namespace.rstrip('/')}/{info.node_name}"


class InputGuard:
    """CommandAuthority and RobotStreamGuard on ``node``, with the node's parameters, logger and clock."""

    def __init__(self, node: Node, values: Mapping[str, Any], authority: CommandAuthority, on_hold) -> None:
        """``authority``: the replica loop's (built from AUTHORITY_PARAMETERS by AuthorityBounds.from_parameters)."""
        self._node = node
        self._on_hold = on_hold  # called once, when the safe hold latches (the node publishes diagnostics)
        self.authority = authority
        self.streams = RobotStreamGuard(future_tolerance=float(values["command_future_tolerance"]))
        # The names after the node's remaps (a driver profile renames /joint_states): count the writers there.
        self._robot_streams = tuple(node.resolve_topic_name(topic) for topic in ROBOT_STREAMS + SET_POINT_STREAMS)
        self._joint_states_topic = self._robot_streams[0]
        self._teleop_topic = node.resolve_topic_name(TELEOP_TOPIC)
        node.create_timer(PUBLISHER_CHECK_PERIOD_S, self._check_publishers)

    @property
    def held(self) -> bool:
        return self.streams.held

    def _now(self) -> float:
        return self._node.get_clock().now().nanoseconds * 1e-9

    def admits_teleop_command(self) -> bool:
        """Whether a teleoperation command may go to the loop at all: not in the safe hold, and one writer on the
        topic (the channel, or the master without one). While a second one is on it, no command can be told from
        the other's: x_d' is held, as when the master is silent (refused, with a throttled error line)."""
        if self.streams.held:
            return False
        writers = self._node.count_publishers(self._teleop_topic)
        if writers > 1:
            reason = f"{writers} publishers on it"
            self.authority.refuse(reason)
            self._node.get_logger().error(
                f"refusing /replica/teleop_command: {reason}, one is the channel's; holding the "
                f"last good x_d' while they last ({self.authority.refused} refused so far)",
                throttle_duration_sec=LOG_THROTTLE_S)
            return False
        return True

    def report(self, verdict: CommandVerdict) -> None:
        """The authority's verdict on a command, logged (throttled): refused, clamped or rate-limited."""
        logger = self._node.get_logger()
        if not verdict.accepted:
            logger.error(f"refusing /replica/teleop_command: {verdict.reason}; keeping the last good x_d' "
                         f"({self.authority.refused} refused so far)", throttle_duration_sec=LOG_THROTTLE_S)
        elif verdict.clamped or verdict.rate_limited:
            logger.warning(f"/replica/teleop_command: {verdict.reason} ({self.authority.clamped} outside the "
                           f"workspace, {self.authority.rate_limited} rate-limited so far)",
                           throttle_duration_sec=LOG_THROTTLE_S)

    def joint_state_usable(self, stamp_seconds: float) -> bool:
        """Whether the joint state stamped so may drive the law (stamps forward, not from the future)."""
        usable, reason = self.streams.joint_state(stamp_seconds, self._now())
        if reason:
            self._hold(reason)
        return usable

    def joint_state_events(self) -> SubscriptionEventCallbacks:
        """For the /joint_states subscription: the middleware's writer-matched event, which comes with a second
        writer's first message or within a message or two (the graph lookup every PUBLISHER_CHECK_PERIOD_S lets a
        loaded machine run the law on that writer's states for as long)."""
        return SubscriptionEventCallbacks(matched=self._on_joint_state_writers)

    def _on_joint_state_writers(self, status) -> None:
        self._on_writers(self._joint_states_topic, status)

    def set_point_events(self, topic: str) -> SubscriptionEventCallbacks:
        """For a set-point subscription (SET_POINT_STREAMS): a second writer matched holds at once, as on
        /joint_states."""
        resolved = self._node.resolve_topic_name(topic)
        return SubscriptionEventCallbacks(matched=lambda status: self._on_writers(resolved, status))

    def _owner(self, topic: str) -> str:
        return "the robot's" if topic in self._robot_streams[:len(ROBOT_STREAMS)] else "the planner's"

    def _on_writers(self, topic: str, status) -> None:
        if status.current_count <= 1 or self.streams.held:
            return
        self._check_publishers()  # names the writers if the graph has them already
        reason = self.streams.matched(topic, status.current_count, self._owner(topic))
        if reason:
            self._hold(reason)

    def _check_publishers(self) -> None:
        if self.streams.held:
            return
        for topic in self._robot_streams:
            writers = [_node_name(info) for info in self._node.get_publishers_info_by_topic(topic)]
            reason = self.streams.publishers(topic, writers, self._owner(topic))
            if reason:
                self._hold(reason)
                return

    def _hold(self, reason: str) -> None:
        self._node.get_logger().error(
            f"SAFE HOLD: {reason}. The replica sends no more torques (no joint state or set-point can be trusted to "
            "be its owner's): the robot's own command watchdog holds the arm, until the replica is restarted "
            "(fic_core.input_authority)")
        self._on_hold()

    def diagnostic_values(self) -> dict[str, str]:
        return {"input_safe_hold": self.streams.reason if self.streams.held else "no",
                "refused_teleop_commands": str(self.authority.refused),
                "last_refusal": self.authority.last_refusal or "none",
                "clamped_teleop_commands": str(self.authority.clamped),
                "rate_limited_teleop_commands": str(self.authority.rate_limited),
                "skipped_joint_states": str(self.streams.skipped_states)}
