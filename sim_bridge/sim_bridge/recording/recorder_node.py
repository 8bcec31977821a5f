"""Recorder node: every topic of the teleoperation graph to a rosbag2-layout MCAP bag (README.md, "What the demo shows").

Wiring only; the file format is sim_bridge.recording.bag_writer. The subscriptions are raw (CDR bytes, never
deserialised) and their callbacks only append (topic index, bytes, receive time) to a deque; a writer thread
drains it into the bag, closes a chunk every `flush_period` (so a SIGKILL loses at most that much), counts
messages per topic and checks /joint_states for gaps. That keeps the executor thread free to take ~8 topics at
1 kHz on a 2-core machine shared with the simulation.

Times: each message's MCAP log_time (and publish_time) is the wall-clock time (ns since the Unix epoch) at which
the subscription handed it over, even under use_sim_time, so that the report can compare sim time (stamps)
with wall time (real-time factor). rclpy's EventsExecutor does not pass MessageInfo to raw callbacks, so the DDS
source timestamp is not available for publish_time.

Dropped joint states: the simulator stamps /joint_states with its own clock, advancing by exactly one physics
step (`joint_states_period`, 1 ms) per message; a jump of n steps between consecutive stamps counts n - 1
dropped messages (wherever they were lost: by the simulator, DDS, or this recorder). Stamps off that grid (the
simulator's realtime mode stamps with its node clock) are counted as such and not gap-checked.

Stopping: SIGINT and SIGTERM (rclpy's handlers shut the context down) or any other rclpy shutdown end the spin;
the writer thread then drains the queue and the bag gets its summary, footer and metadata.yaml.
"""
from __future__ import annotations

import gc
import collections
import datetime
import re
import signal
import struct
import threading
import time
from pathlib import Path

import rclpy
from rclpy.signals import SignalHandlerOptions
from sim_bridge import stop_signals
from rclpy.clock import Clock, ClockType
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType
from rclpy.executors import ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.task import Future
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from fic_core.errors import FicInputError
from sim_bridge.recording.bag_writer import BagError, BagWriter, MessageDefinitionError, full_type_name, message_definition, \
    qos_profile_dict
from sim_bridge.recording.live_view import LiveView, LiveViewError
from sim_bridge.message_types import message_class

# The topic table of docs/INTERFACES.md: what a session is.
DEFAULT_TOPICS = [
    "/haptic/pose", "/haptic/twist", "/haptic/wrench_command", "/operator/joy",
    "/master/pose", "/master/teleop_command", "/master/feedback_wrench",
    "/replica/master_pose", "/replica/teleop_command", "/replica/feedback_wrench",
    "/planner/desired_pose", "/planner/desired_accel", "/replica/desired_pose", "/replica/tcp_pose",
    "/replica/fic_state", "/replica/limit_status",
    "/joint_states", "/ft_sensor/wrench", "/clock", "/effort_controller/commands",
    "/channel/deliveries", "/diagnostics", "/sim/step_lateness",
    # The robot sim's ground truth (robot_node, 50 Hz): where the E2 pieces ended (success), the true TCP pose.
    "/sim/object_poses", "/sim/tcp_pose",
]
# Subscriber QoS: RELIABLE so that DDS resends what a busy recorder missed, KEEP_LAST deep enough to absorb a
# 1 s stall of the writer at 1 kHz (docs/CONVENTIONS.md, "QoS": the robot keeps 1000 too; a deeper reader queue is free).
# BEST_EFFORT / TRANSIENT_LOCAL only when every publisher offers it (a reliable reader cannot match a
# best-effort writer; transient-local gets the latched sample).
DEFAULT_QUEUE_DEPTH = 1000


def _descriptor(description: str, *, type_: int | None = None, float_range: tuple[float, float] | None = None,
                int_range: tuple[int, int] | None = None) -> ParameterDescriptor:
    descriptor = ParameterDescriptor(description=description)
    if type_ is not None:
        descriptor.type = type_
    if float_range is not None:
        descriptor.floating_point_range = [FloatingPointRange(from_value=float_range[0], to_value=float_range[1])]
    if int_range is not None:
        descriptor.integer_range = [IntegerRange(from_value=int_range[0], to_value=int_range[1], step=1)]
    return descriptor


class JointStateGapCounter:
    """Counts messages missing from a stream whose header stamps advance by exactly one period per message."""

    def __init__(self, period_ns: int) -> None:
        self.period_ns = period_ns
        self.received = 0
        self.dropped = 0
        self.gaps = 0
        self.out_of_order = 0
        self.off_grid = 0  # stamps not on the step grid (realtime mode stamps with the node clock)
        self._last_ns: int | None = None

    def add(self, cdr: bytes) -> None:
        # CDR: 4-byte encapsulation header (byte 1: 1 = little endian), then std_msgs/Header.stamp (int32, uint32).
        sec, nanosec = struct.unpack_from("<iI" if cdr[1] & 1 else ">iI", cdr, 4)
        stamp = sec * 1_000_000_000 + nanosec
        self.received += 1
        offset = stamp % self.period_ns
        if min(offset, self.period_ns - offset) > 1000:  # more than 1 us off a step: not a sim-time stamp
            self.off_grid += 1
            self._last_ns = None
            return
        if self._last_ns is not None:
            delta = stamp - self._last_ns
            if delta <= 0:
                self.out_of_order += 1
                return
            missing = round(delta / self.period_ns) - 1
            if missing > 0:
                self.dropped += missing
                self.gaps += 1
        self._last_ns = stamp


class RecorderNode(Node):
    def __init__(self) -> None:
        super().__init__("recorder")
        self.declare_parameter("bag_path", "", _descriptor(
            "bag folder to create (rosbag2 layout: <bag_path>/<name>_0.mcap + metadata.yaml); "
            "empty: bags/rosbag2_<date>-<time> in the working directory"))
        self.declare_parameter("topics", DEFAULT_TOPICS, _descriptor(
            "topics to record as they appear in the graph (default: the topic table of docs/INTERFACES.md)",
            type_=ParameterType.PARAMETER_STRING_ARRAY))
        self.declare_parameter("all", False, _descriptor(
            "record every topic the graph discovery finds (besides `topics`), except `exclude`"))
        self.declare_parameter("exclude", ["/rosout", "/parameter_events"], _descriptor(
            "regular expressions of topics that `all` leaves out", type_=ParameterType.PARAMETER_STRING_ARRAY))
        self.declare_parameter("discovery_period", 0.5, _descriptor(
            "seconds between graph discoveries of new topics", float_range=(0.05, 60.0)))
        self.declare_parameter("queue_depth", DEFAULT_QUEUE_DEPTH, _descriptor(
            "KEEP_LAST depth of every subscription", int_range=(1, 100000)))
        self.declare_parameter("chunk_size", 256 * 1024, _descriptor(
            "MCAP chunk size in bytes (uncompressed): a chunk is closed when it reaches this size",
            int_range=(1024, 64 * 1024 * 1024)))
        self.declare_parameter("flush_period", 0.5, _descriptor(
            "seconds between forced chunk closes: the most a SIGKILL can lose", float_range=(0.01, 60.0)))
        self.declare_parameter("compression", "zstd", _descriptor("chunk compression: zstd, lz4 or none"))
        self.declare_parameter("status_period", 1.0, _descriptor(
            "seconds between recorder status messages on /diagnostics", float_range=(0.1, 60.0)))
        self.declare_parameter("joint_states_topic", "/joint_states", _descriptor(
            "topic whose header stamps are checked for gaps"))
        self.declare_parameter("joint_states_period", 0.001, _descriptor(
            "seconds between consecutive joint-state stamps (the simulator's physics step)",
            float_range=(1e-6, 1.0)))
        # The live view (sim_bridge/live_view.py): the recorded topics on a Foxglove WebSocket server.
        self.declare_parameter("live_port", 0, _descriptor(
            "TCP port of the live view's Foxglove WebSocket server; 0: no live view", int_range=(0, 65535)))
        self.declare_parameter("live_host", "127.0.0.1", _descriptor(
            "address the live view binds to (127.0.0.1: this machine only)"))
        self.declare_parameter("live_rate", 30.0, _descriptor(
            "most messages a second the live view sends of any one topic", float_range=(0.1, 1000.0)))

        bag_path = self.get_parameter("bag_path").value or \
            f"bags/rosbag2_{datetime.datetime.now().strftime('%Y_%m_%d-%H_%M_%S')}"
        self._topics = list(self.get_parameter("topics").value or [])
        self._record_all = bool(self.get_parameter("all").value)
        self._exclude = [re.compile(p) for p in self.get_parameter("exclude").value or []]
        self._queue_depth = int(self.get_parameter("queue_depth").value)
        self._joint_states_topic = str(self.get_parameter("joint_states_topic").value)
        # Before the bag folder exists: a port in use leaves nothing behind.
        self.live = None
        if self.get_parameter("live_port").value:
            self.live = LiveView(host=str(self.get_parameter("live_host").value),
                                 port=int(self.get_parameter("live_port").value),
                                 view_rate=float(self.get_parameter("live_rate").value),
                                 joint_states_topic=self._joint_states_topic)
            self.get_logger().info(f"live view on ws://{self.get_parameter('live_host').value}:{self.live.port}")

        self.bag = BagWriter(Path(bag_path), chunk_size=int(self.get_parameter("chunk_size").value),
                             compression=str(self.get_parameter("compression").value),
                             flush_period=float(self.get_parameter("flush_period").value))
        self.joint_states = JointStateGapCounter(round(self.get_parameter("joint_states_period").value * 1e9))
        # (topic index, cdr bytes, receive time ns), or (None, (topic, type, qos profiles), 0) to add a topic.
        self._queue: collections.deque = collections.deque()
        self._topic_names: list[str] = []
        self._channel_ids: list[int] = []  # MCAP channel id per topic index (writer thread)
        self._recorded: dict[str, object] = {}
        self._skipped: set[str] = set()
        self._counts: list[int] = []
        self._max_backlog = 0
        self._stop = threading.Event()
        self._finish_lock = threading.Lock()
        self._finished = False
        self._writer_error: BaseException | None = None
        self._writer = threading.Thread(target=self._write_loop, name="bag_writer", daemon=True)
        self._writer.start()

        self._status_publisher = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        # Discovery on the wall clock: under simulated time the lockstep simulation stands at t = 0 until the
        # replica answers, and a sim-time timer would not look for topics until it moved on (the first 0.6 s of
        # /joint_states of a lockstep run were missed that way).
        self.create_timer(float(self.get_parameter("discovery_period").value), self._discover,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.create_timer(float(self.get_parameter("status_period").value), self._publish_status)
        self._discover()
        self.get_logger().info(f"recording to {self.bag.bag_dir.resolve()} "
                               f"({'all topics' if self._record_all else f'{len(self._topics)} topics'})")

    # -- discovery and subscriptions (executor thread) --------------------------------------------------------
    def _wanted(self, topic: str) -> bool:
        if topic in self._topics:
            return True
        return self._record_all and not any(p.fullmatch(topic) for p in self._exclude)

    def _discover(self) -> None:
        for topic, types in self.get_topic_names_and_types():
            if topic in self._recorded or topic in self._skipped or not self._wanted(topic):
                continue
            self._subscribe(topic, types)

    def _subscribe(self, topic: str, types: list[str]) -> None:
        if len(types) != 1:
            self.get_logger().warning(f"not recording {topic}: published with {len(types)} types {types}")
            self._skipped.add(topic)
            return
        type_name = types[0]
        try:
            subscription_type = message_class(type_name)
        except FicInputError as error:
            self.get_logger().warning(f"not recording {topic}: type {type_name} is not importable ({error})")
            self._skipped.add(topic)
            return
        publishers = self.get_publishers_info_by_topic(topic)
        if not publishers:
            # Only readers known so far (a subscriber announces the topic too): without a publisher's QoS a
            # reliable guess would never match a best-effort driver stream (franka_ros2's wrench); next discovery.
            return
        reliable = all(p.qos_profile.reliability != ReliabilityPolicy.BEST_EFFORT for p in publishers)
        latched = bool(publishers) and all(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
                                           for p in publishers)
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=self._queue_depth,
                         reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)
        offered = [qos_profile_dict(reliability=p.qos_profile.reliability.name.lower(),
                                    durability=p.qos_profile.durability.name.lower(),
                                    history=p.qos_profile.history.name.lower(), depth=p.qos_profile.depth)
                   for p in publishers]
        index = len(self._topic_names)
        self._topic_names.append(topic)
        self._counts.append(0)
        # The bag learns the topic before its first message: the queue is FIFO.
        self._queue.append((None, (topic, type_name, offered), 0))
        self._recorded[topic] = self.create_subscription(subscription_type, topic, self._enqueuer(index), qos,
                                                         raw=True)
        self.get_logger().info(f"recording {topic} [{type_name}] "
                               f"({qos.reliability.name.lower()}, {qos.durability.name.lower()}, depth {qos.depth})")

    def _enqueuer(self, index: int):
        # One argument only: rclpy takes a callback that also accepts a second argument for a MessageInfo
        # callback, which the EventsExecutor cannot serve (a default argument would trip that check).
        append, now = self._queue.append, time.time_ns

        def enqueue(data: bytes) -> None:
            append((index, data, now()))
        return enqueue

    # -- writing (writer thread) ------------------------------------------------------------------------------
    def _write_loop(self) -> None:
        queue, bag, counts, live = self._queue, self.bag, self._counts, self.live
        try:
            while True:
                stopping = self._stop.is_set()
                backlog = len(queue)
                self._max_backlog = max(self._max_backlog, backlog)
                while queue:
                    index, data, stamp = queue.popleft()
                    if index is None:
                        self._add_topic(*data)
                        continue
                    bag.write(self._channel_ids[index], data, stamp)
                    counts[index] += 1
                    if live is not None:
                        live.offer(self._topic_names[index], data, stamp)
                    if self._topic_names[index] == self._joint_states_topic:
                        self.joint_states.add(data)
                if stopping:
                    return
                if not bag.maybe_flush():
                    time.sleep(0.002)
        except BaseException as error:  # the executor thread reports it; recording cannot go on
            self._writer_error = error
            raise

    def _add_topic(self, topic: str, type_name: str, offered: list[dict]) -> None:
        try:
            definition = message_definition(full_type_name(type_name))
        except MessageDefinitionError as error:
            self.get_logger().warning(f"{topic}: {error}; recorded without a message definition")
            definition = ""
        channel_id = self.bag.add_topic(topic, type_name, offered_qos_profiles=offered or None, definition=definition)
        self._channel_ids.append(channel_id)
        if self.live is not None:
            self.live.add_topic(topic, self.bag.topics[topic].type, definition)

    # -- status and finishing ---------------------------------------------------------------------------------
    def counts(self) -> dict[str, int]:
        return dict(zip(self._topic_names, self._counts))

    def _publish_status(self) -> None:
        if self._writer_error is not None:
            self.get_logger().error(f"bag writer failed: {self._writer_error!r}")
            raise self._writer_error
        status = DiagnosticStatus(level=DiagnosticStatus.OK, name="recorder", hardware_id=str(self.bag.bag_dir),
                                  message=f"{sum(self._counts)} messages on {len(self._topic_names)} topics")
        if self.joint_states.dropped:
            status.level = DiagnosticStatus.WARN
            status.message += f"; {self.joint_states.dropped} joint states dropped"
        values = {"bag": str(self.bag.bag_dir), "backlog": len(self._queue), "max_backlog": self._max_backlog,
                  "joint_states_received": self.joint_states.received,
                  "joint_states_dropped": self.joint_states.dropped,
                  "joint_states_out_of_order": self.joint_states.out_of_order,
                  "joint_states_off_step_grid": self.joint_states.off_grid}
        values.update({f"count {topic}": count for topic, count in self.counts().items()})
        status.values = [KeyValue(key=key, value=str(value)) for key, value in values.items()]
        message = DiagnosticArray(status=[status])
        message.header.stamp = self.get_clock().now().to_msg()
        self._status_publisher.publish(message)

    def _log_info(self, line: str) -> None:
        # After a signal the context is already shut down and the logger could not reach /rosout.
        if self.context.ok():
            self.get_logger().info(line)
        else:
            print(f"[INFO] [{time.time():.9f}] [{self.get_name()}]: {line}", flush=True)

    def finish(self) -> None:
        """Drain the queue, write the summary/footer and metadata.yaml, and log the counts. Idempotent."""
        with self._finish_lock:
            if self._finished:
                return
            self._finished = True
            for subscription in list(self._recorded.values()):
                self.destroy_subscription(subscription)
            self._stop.set()
            self._writer.join()
            summary = self.bag.finish()
            if self.live is not None:
                self.live.stop()
            per_topic = ", ".join(f"{topic} {count}" for topic, count in sorted(summary.topics.items()))
            self._log_info(
                f"finished bag {summary.bag_dir.resolve()}: {summary.message_count} messages on "
                f"{len(summary.topics)} topics ({per_topic}); {self._joint_states_topic}: "
                f"{self.joint_states.received} received, {self.joint_states.dropped} dropped in "
                f"{self.joint_states.gaps} gaps, {self.joint_states.out_of_order} out of order, "
                f"{self.joint_states.off_grid} off the step grid (not gap-checked); "
                f"max backlog {self._max_backlog}")


def main(args: list[str] | None = None) -> None:
    # rclpy's own handlers take SIGINT and SIGTERM and shut the context down; spin() then returns (or raises)
    # and the bag is finished below. A second signal during finishing is ignored so it cannot cut the footer.
    stop_signals.install()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)  # our handlers: stop_signals.py
    node = None
    try:
        try:
            node = RecorderNode()
        except BagError as exc:  # an existing bag folder, an unwritable path: one clear line, not a traceback
            rclpy.logging.get_logger("recorder").fatal(f"cannot record: {exc}")
            raise SystemExit(2) from exc
        except LiveViewError as exc:  # the live view's port is taken: one line, and no bag was started
            rclpy.logging.get_logger("recorder").fatal(str(exc))
            raise SystemExit(2) from exc
        executor = EventsExecutor()
        executor.add_node(node)
        # The start-up heap (rclpy, numpy, Pinocchio, MuJoCo: ~60k objects) moved out of the collector's reach: a
        # full collection of it took 25 ms here, and with it every loop in the graph stalled every few seconds.
        gc.collect()
        gc.freeze()
        # Spin in bounded slices: with the rclpy 7.1 wheels, EventsExecutor.spin() and spin_until_future_complete
        # without a timeout busy-loop without ever running a timer; with a timeout they work.
        never = Future()
        try:
            stop_signals.running()  # a signal now asks the loop to stop; the bag is finished below
            while rclpy.ok() and not stop_signals.requested():
                executor.spin_until_future_complete(never, timeout_sec=0.5)
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
    finally:
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, signal.SIG_IGN)
        if node is not None:
            node.finish()
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
