"""ROS 2 shell around the delay/dropout channel (sim_bridge/channel/channel.py): one direction of the master-replica
link.

Each route ``in_topic:out_topic:pkg/msg/Type`` is a raw (CDR bytes) subscription, a ``Channel`` and a raw
publisher, so any message type passes untouched and its header stamp is preserved. Run one instance per
direction (config/channel.yaml: ``channel_forward`` master -> replica, ``channel_backward`` replica -> master).
Every link parameter can be changed at run time (``scripts/fic param set /channel_forward delay 0.5``, or
``ros2 param set`` with a full ROS 2 install); the change
applies to all routes of this node. Time is the node clock, so with use_sim_time the delay is in simulated time
and runs in lockstep with the simulator.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import Header

from fic_core.errors import FicInputError
from fic_teleop_runtime import qos
from fic_teleop_runtime.cdr_header import header_stamp, stamp_seconds
from fic_teleop_runtime.message_types import message_class
from fic_teleop_runtime.node_main import NodeEntry, run_entry
from fic_teleop_runtime.parameters import Schema, declare
from fic_teleop_runtime.periodic import PeriodicCallbacks
from fic_teleop_runtime.stamps import time_message
from sim_bridge.channel.channel import Channel, ChannelConfig
from sim_bridge.channel.channel_parameters import CHANNEL_PARAMETERS, ChannelParameters, channel_config

try:
    from fic_teleop_msgs.msg import ChannelDelivery
except ImportError:          # the message package is not built: the channel still works, without that topic
    ChannelDelivery = None

# Teleoperation streams through the channel (docs/CONVENTIONS.md): read RELIABLE, KEEP_LAST 20, written with the
# streams' deep writer history (a stalled reader loses nothing). The channel is where loss is injected on
# purpose; DDS itself should add none.
CHANNEL_QOS, CHANNEL_WRITER_QOS = qos.STREAM, qos.STREAM_WRITER
# One ChannelDelivery per forwarded message, read by the recorder: a stream's writer too.
DELIVERY_QOS = qos.STREAM_WRITER
DIAGNOSTICS_QOS = qos.DIAGNOSTICS
# The lockstep heartbeat: only the newest stamp matters to the robot's peer barrier.
HEARTBEAT_QOS = qos.NEWEST

# Parameters that reconfigure the links at run time; ``routes`` and the timer rates are fixed at start.
LINK_PARAMETERS = ("delay", "jitter", "jitter_distribution", "allow_reorder", "drop_probability",
                   "blackout_windows", "lost_from", "rate_cap_hz", "seed", "time_reference")


SCHEMA = Schema("channel.yaml", CHANNEL_PARAMETERS.values())


@dataclass
class Route:
    in_topic: str
    out_topic: str
    type_name: str
    has_header: bool
    channel: Channel
    publisher: Any
    subscription: Any = None
    logged: bool = True       # its deliveries go on /channel/deliveries


def starts_with_header(cls: type) -> bool:
    """True if the CDR form begins with a header stamp: first field std_msgs/Header, or a Header itself."""
    fields = list(cls.get_fields_and_field_types().items())
    if not fields:
        return False
    first_type = fields[0][1]
    return first_type == "std_msgs/Header" or (fields[0][0] == "stamp" and first_type == "builtin_interfaces/Time")


def parse_route(text: str) -> tuple[str, str, str]:
    parts = text.split(":")
    if len(parts) != 3 or not all(parts):
        raise FicInputError(f"route must be 'in_topic:out_topic:pkg/msg/Type', got {text!r}")
    return parts[0], parts[1], parts[2]


class ChannelNode(Node):
    def __init__(self, **node_options) -> None:  # node_options: rclpy Node keywords (node_group.py)
        super().__init__("channel", **node_options)
        self._periodic = PeriodicCallbacks(self)  # timers that follow the simulated clock (periodic.py)
        # Every row with its config/channel.yaml value (unknown keys refused), kept as the links run them.
        p = self._link_parameters = ChannelParameters.from_values(declare(self, SCHEMA))
        self._origin = self._now()           # "start" time reference: blackout/lost_from relative to this
        config = self._config_from(p)
        if not p.routes:
            raise FicInputError("parameter routes is empty: give at least one in_topic:out_topic:pkg/msg/Type")
        specs = list(p.routes)
        seeds = route_seeds(config.seed, len(specs))
        self._routes: list[Route] = []
        for spec, seed in zip(specs, seeds):
            in_topic, out_topic, type_name = parse_route(spec)
            cls = message_class(type_name)
            route = Route(in_topic, out_topic, type_name, starts_with_header(cls),
                          Channel(dataclasses.replace(config, seed=seed)),
                          self.create_publisher(cls, out_topic, CHANNEL_WRITER_QOS))
            route.subscription = self.create_subscription(
                cls, in_topic, lambda data, route=route: self._on_message(route, data), CHANNEL_QOS, raw=True)
            self._routes.append(route)
            self.get_logger().info(f"route {in_topic} -> {out_topic} [{type_name}]"
                                   + ("" if route.has_header else " (no header: stamps not read)"))
        # The delivery log only where a figure reads it (the report's latency and delay: the teleoperation command;
        # the two-station analysis: F_R; the closed-loop operator's video): one ChannelDelivery per forwarded port
        # energy too was 175 messages a second that nothing read, published here and taken by the recorder.
        logged = p.logged_deliveries
        if logged:
            unknown = sorted(set(logged) - {route.out_topic for route in self._routes})
            if unknown:
                raise FicInputError(f"logged_deliveries names {', '.join(unknown)}, not an out topic of this node's "
                                    f"routes ({', '.join(route.out_topic for route in self._routes)})")
            for route in self._routes:
                route.logged = route.out_topic in logged
        self._deliveries = None
        if p.publish_deliveries:
            if ChannelDelivery is None:
                self.get_logger().warning("fic_teleop_msgs is not built: /channel/deliveries is not published")
            else:
                self._deliveries = self.create_publisher(ChannelDelivery, "/channel/deliveries", DELIVERY_QOS)
        self._diagnostics = self.create_publisher(DiagnosticArray, "/diagnostics", DIAGNOSTICS_QOS)
        # Lockstep: the simulation steps only as far as this node's clock has got (the robot's peer barrier reads the
        # stamp). A channel process that fell behind the simulation held each command as long again as it lagged, and
        # its 20-deep readers dropped commands that queued meanwhile (6-29 of an E1 run's, 2026-12-06).
        self._heartbeat = self.create_publisher(Header, "~/heartbeat", HEARTBEAT_QOS) if p.lockstep_heartbeat \
            else None
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._periodic.create(1.0 / p.delivery_rate_hz, self._deliver)
        self._periodic.create(1.0 / p.statistics_rate_hz, self._publish_statistics)
        self.get_logger().info(f"channel up: {self._describe(config)}")

    # -- parameters -------------------------------------------------------------------------------------------
    def _config_from(self, p: ChannelParameters) -> ChannelConfig:
        """The links' configuration of ``p``, on this node's start (FicInputError for a value its row cannot refuse
        alone)."""
        return channel_config(p, self._origin)

    def _on_set_parameters(self, changes: list[Parameter]) -> SetParametersResult:
        link_changes = {p.name: p.value for p in changes if p.name in LINK_PARAMETERS}
        if not link_changes:
            return SetParametersResult(successful=True)
        try:
            candidate = self._link_parameters.replaced(link_changes)
            config = self._config_from(candidate)
        except FicInputError as exc:
            self.get_logger().error(f"channel parameters refused: {exc}")
            return SetParametersResult(successful=False, reason=str(exc))
        self._link_parameters = candidate
        seeds = route_seeds(config.seed, len(self._routes))
        for route, seed in zip(self._routes, seeds):
            # A changed seed restarts each route's stream from its route seed, as at start; otherwise the
            # streams continue undisturbed.
            route.channel.reconfigure(dataclasses.replace(
                config, seed=seed if "seed" in link_changes else route.channel.config.seed))
        self.get_logger().info(f"channel reconfigured: {self._describe(config)}")
        return SetParametersResult(successful=True)

    def _describe(self, config: ChannelConfig) -> str:
        windows = [(round(a - self._origin, 3), round(b - self._origin, 3)) for a, b in config.blackout_windows]
        return (f"delay={config.delay:.4f}s jitter={config.jitter:.4f}s ({config.jitter_distribution}) "
                f"drop={config.drop_probability:.3f} blackouts(from start)={windows} "
                f"lost_from={'never' if config.lost_from is None else round(config.lost_from - self._origin, 3)} "
                f"rate_cap={config.rate_cap_hz:g}Hz seed={config.seed}")

    # -- data path ----------------------------------------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_message(self, route: Route, data: bytes) -> None:
        stamp = header_stamp(data) if route.has_header else None
        route.channel.push(data, None if stamp is None else stamp_seconds(stamp), self._now())

    def _deliver(self) -> None:
        now = self._now()
        for route in self._routes:
            for delivery in route.channel.pop_due(now):
                route.publisher.publish(delivery.payload)
                if self._deliveries is not None and route.logged:
                    record = ChannelDelivery()
                    stamp = header_stamp(delivery.payload) if route.has_header else None
                    if stamp is not None:
                        record.header.stamp = Time(sec=stamp[0], nanosec=stamp[1])
                    record.topic = route.out_topic
                    record.received = time_message(round(delivery.received_time * 1e9))
                    record.held = delivery.held
                    self._deliveries.publish(record)
        if self._heartbeat is not None:   # after the deliveries: everything due by ``now`` is out
            self._heartbeat.publish(Header(stamp=time_message(round(now * 1e9))))

    def _publish_statistics(self) -> None:
        now = self._now()
        array = DiagnosticArray()
        array.header.stamp = self.get_clock().now().to_msg()
        for route in self._routes:
            stats = route.channel.statistics()
            config = route.channel.config
            down = config.link_down(now)
            status = DiagnosticStatus(name=f"{self.get_name()}: {route.in_topic} -> {route.out_topic}",
                                      hardware_id="sim_bridge/channel/channel")
            status.level = DiagnosticStatus.WARN if down else DiagnosticStatus.OK
            status.message = ("link down" if down else "link up") + (
                f", held p50 {stats.held_p50 * 1e3:.1f} ms" if not math.isnan(stats.held_p50) else "")
            values = {"received": stats.received, "delivered": stats.delivered, "queue_size": stats.queue_size,
                      "dropped_total": stats.dropped_total,
                      **{f"dropped_{cause}": count for cause, count in stats.dropped.items()},
                      "held_p50_ms": stats.held_p50 * 1e3, "held_p99_ms": stats.held_p99 * 1e3,
                      "held_max_ms": stats.held_max * 1e3, "age_p50_ms": stats.age_p50 * 1e3,
                      "age_p99_ms": stats.age_p99 * 1e3, "delay_set_ms": config.delay * 1e3,
                      "drop_probability": config.drop_probability, "rate_cap_hz": config.rate_cap_hz}
            status.values = [KeyValue(key=key, value=f"{value:.3f}" if isinstance(value, float) else str(value))
                             for key, value in values.items()]
            array.status.append(status)
        self._diagnostics.publish(array)

    def summary(self) -> str:
        lines = []
        for route in self._routes:
            s = route.channel.statistics()
            lines.append(f"{route.in_topic} -> {route.out_topic}: received {s.received}, delivered {s.delivered}, "
                         f"dropped {s.dropped}, held p50 {s.held_p50 * 1e3:.2f} ms p99 {s.held_p99 * 1e3:.2f} ms")
        return "; ".join(lines)


def route_seeds(seed: int | None, count: int) -> list[int | None]:
    """One independent random stream per route, all derived from the one seed: reproducible, uncorrelated."""
    if seed is None:
        return [None] * count
    return [int(s) for s in np.random.SeedSequence(seed).generate_state(count)]


def main(args: list[str] | None = None) -> None:
    run_entry(ENTRY, args)


ENTRY = NodeEntry(ChannelNode, "channel", follow_sim_time=False,
                  stopped=lambda node: rclpy.logging.get_logger(node.get_name()).info(
                      f"channel stopped: {node.summary()}"))


if __name__ == "__main__":
    main()
