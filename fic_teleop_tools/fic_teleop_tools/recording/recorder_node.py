"""Recorder node: every topic of the teleoperation graph to a rosbag2-layout MCAP bag (README.md, "What the demo
shows").

Wiring only; the file format is fic_teleop_tools.recording.bag_writer. The subscriptions are raw (CDR bytes, never
deserialised) and belong to a second node of this process that no executor spins (``<name>_reader``): a taker
thread takes whatever each holds every `drain_period` (10 ms) and appends it, in order of arrival, to a deque; a
writer thread drains the deque into the bag, closes a chunk every `flush_period` (so a SIGKILL loses at most that
much), counts messages per topic and checks /joint_states for gaps. A message taken by the executor cost the
recorder a wake-up and a callback each: 103 us a message against 29-43 us taken in rounds (measured with one 500 Hz
stream), and the recorder takes about 2,500 messages a second. The taker does nothing else, so that the writer's
slow moments (a topic's definition, a chunk's compression) never leave a subscription's 1000-deep queue to
overflow. The executor thread only discovers topics and publishes the status. With `count_lost_messages` the
subscriptions are the recorder node's own instead, as before (their message-lost events need the executor), and
their callbacks append to the deque.

Batched streams (fic_teleop_runtime/record_batch.py): a fast stream whose every publisher also publishes its samples
in batches on ``/record<topic>`` (the robot's joint states and wrench, the torque command, the haptic pose and force
command) is recorded from the batches: the taker takes a batch (every 50 ms) instead of 25-50 messages, and the writer
writes each sample under the topic itself, with its publication time as log_time and publish_time. The choice is made
per topic when it is found, by the publishing nodes: if any publisher of the topic has no batches (a real driver, a
second writer), the topic is recorded message by message as before and its batches are not taken. Since a batch's
samples arrive up to a batch period late, the writer holds every message ``reorder_window`` (only while some topic is
batched) and writes them in time order; a sample later than that is written out of order (counted; MCAP readers
that read by time sort it). A SIGKILL then loses at most ``flush_period`` + ``reorder_window``.

Times: each message's MCAP log_time is the wall-clock time (ns since the Unix epoch) at which DDS received it
(MessageInfo's received_timestamp, taken in rounds) and its publish_time the publisher's (source_timestamp), even
under use_sim_time, so that the report can compare sim time (stamps) with wall time (real-time factor). In the
executor's path (`count_lost_messages`) both are the time the callback ran: rclpy's EventsExecutor does not pass
MessageInfo to raw callbacks.

Dropped joint states: the simulator stamps /joint_states with its own clock, advancing by exactly one physics
step (`joint_states_period`, 1 ms) per message; a jump of n steps between consecutive stamps counts n - 1
dropped messages (wherever they were lost: by the simulator, DDS, or this recorder). Stamps off that grid (the
simulator's realtime mode stamps with its node clock) are counted as such and not gap-checked.

Lost messages (``count_lost_messages``, off by default): every subscription counts DDS's message-lost events
(samples a writer no longer held when this reader asked for them again: a reliable KEEP_LAST writer overwrites what
a stalled reader has not acknowledged). The counts per topic go to /diagnostics, to the last log line and to the
bag's metadata.yaml (`custom_data` `lost_messages`, JSON), so that a report can say what the bag is missing. A
sample this recorder's own queue dropped is not in that count (its depth is 1000: a stall of a second at 1 kHz);
/joint_states' gap check sees it. Off by default because with Jazzy's rmw_fastrtps (8.4.3) taking that event can
deadlock against Fast DDS's own listener exactly when samples are lost, and the wedged recorder records nothing
more (docs/RESULTS.md, "Faults and hostile input"); off, the bag says the losses were not counted (no
`lost_messages` key) and /joint_states' gap check remains.

Stopping: SIGINT and SIGTERM (rclpy's handlers shut the context down) or any other rclpy shutdown end the spin;
the writer thread then drains the queue and the bag gets its summary, footer and metadata.yaml.
"""
from __future__ import annotations

import collections
import datetime
import heapq
import itertools
import json
import re
import threading
import time
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from fic_core.errors import FicInputError
from fic_core.parameter_row import parameter_set
from fic_teleop_runtime.cdr_header import header_stamp
from fic_teleop_runtime.message_types import message_class
from fic_teleop_runtime.node_main import NodeEntry, run_entry
from fic_teleop_runtime.parameters import Schema, declare, defaults_for, integer, number, switch, text, texts
from fic_teleop_runtime.record_batch import RECORD_BATCH_TYPE, record_topic, unpack
from fic_teleop_tools.recording.bag_writer import (
    BagError,
    BagWriter,
    MessageDefinitionError,
    full_type_name,
    message_definition,
    qos_profile_dict,
)
from fic_teleop_tools.recording.live_view import LiveView, LiveViewError

# Subscriber QoS: RELIABLE so that DDS resends what a busy recorder missed, KEEP_LAST deep enough to absorb a
# 1 s stall of the writer at 1 kHz (docs/CONVENTIONS.md, "QoS": the robot keeps 1000 too; a deeper reader queue is
# free). BEST_EFFORT / TRANSIENT_LOCAL only when every publisher offers it (a reliable reader cannot match a
# best-effort writer; transient-local gets the latched sample).
SCHEMA = Schema(
    "recorder.yaml",
    text("bag_path", "bag folder to create (rosbag2 layout: <bag_path>/<name>_0.mcap + metadata.yaml); empty: "
                     "bags/rosbag2_<date>-<time> in the working directory"),
    texts("topics", "topics to record as they appear in the graph (config: the topic table of "
                    "docs/INTERFACES.md)"),
    switch("all", "record every topic the graph discovery finds (besides `topics`), except `exclude`"),
    texts("exclude", "regular expressions of topics that `all` leaves out"),
    number("discovery_period", 0.05, 60.0, "seconds between graph discoveries of new topics"),
    integer("queue_depth", 1, 100000, "KEEP_LAST depth of every subscription"),
    switch("count_lost_messages", "count DDS's message-lost events per topic (off: with Jazzy's rmw_fastrtps the "
                                  "event can deadlock the recorder when samples are lost)"),
    integer("chunk_size", 1024, 64 * 1024 * 1024, "MCAP chunk size in bytes (uncompressed): a chunk is closed when "
                                                  "it reaches this size"),
    number("flush_period", 0.01, 60.0, "seconds between forced chunk closes: the most a SIGKILL can lose"),
    number("drain_period", 0.001, 1.0, "seconds between the writer thread's rounds over the subscriptions"),
    number("reorder_window", 0.0, 10.0, "seconds every message is held before it is written, while some topic comes "
                                        "in batches (/record/<topic>), so that the bag stays in time order"),
    text("compression", "chunk compression: zstd, lz4 or none"),
    number("status_period", 0.1, 60.0, "seconds between recorder status messages on /diagnostics"),
    text("joint_states_topic", "topic whose header stamps are checked for gaps"),
    number("joint_states_period", 1e-6, 1.0, "seconds between consecutive joint-state stamps (the simulator's "
                                             "physics step)"),
    # The live view (fic_teleop_tools/recording/live_view.py): the recorded topics on a Foxglove WebSocket server.
    integer("live_port", 0, 65535, "TCP port of the live view's Foxglove WebSocket server; 0: no live view"),
    text("live_host", "address the live view binds to (127.0.0.1: this machine only)"),
    number("live_rate", 0.1, 1000.0, "most messages a second the live view sends of any one topic"),
)

#: The recorder's parameters as one typed object, one field a row of SCHEMA (fic_core.parameter_row): a name no row
#: has is refused, naming the nearest.
RecorderParameters = parameter_set("RecorderParameters", __name__, "recorder", SCHEMA.rows,
                                   "The recorder's parameters (SCHEMA), checked, one field a row.")


def default_topics() -> list[str]:
    """The topics a session records (config/recorder.yaml: the topic table of docs/INTERFACES.md)."""
    return list(defaults_for(SCHEMA, "recorder")["topics"])


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
        self.received += 1
        parsed = header_stamp(cdr)  # std_msgs/Header.stamp right after the CDR encapsulation
        if parsed is None:
            return  # not a stamp: nothing to place on the step grid
        stamp = parsed[0] * 1_000_000_000 + parsed[1]
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
    def __init__(self, **node_options) -> None:  # node_options: rclpy Node keywords (node_group.py)
        super().__init__("recorder", **node_options)
        # Every row with its config/recorder.yaml value; unknown keys refused.
        self.parameters = p = RecorderParameters.from_values(declare(self, SCHEMA))
        bag_path = p.bag_path or f"bags/rosbag2_{datetime.datetime.now().strftime('%Y_%m_%d-%H_%M_%S')}"
        self._topics = list(p.topics or [])
        self._record_all = p.all
        self._exclude = [re.compile(pattern) for pattern in p.exclude or []]
        self._queue_depth = p.queue_depth
        self._count_lost = p.count_lost_messages
        self._joint_states_topic = p.joint_states_topic
        # Before the bag folder exists: a port in use leaves nothing behind.
        self.live = None
        if p.live_port:
            self.live = LiveView(host=p.live_host, port=p.live_port, view_rate=p.live_rate,
                                 joint_states_topic=self._joint_states_topic)
            self.get_logger().info(f"live view on ws://{p.live_host}:{self.live.port}")

        self.bag = BagWriter(Path(bag_path), chunk_size=p.chunk_size, compression=p.compression,
                             flush_period=p.flush_period)
        self.joint_states = JointStateGapCounter(round(p.joint_states_period * 1e9))
        # (topic index, cdr bytes, receive time ns, publish time ns or None), (topic index, a RecordBatch's cdr bytes,
        # receive time ns, BATCH), or (None, (topic, type, qos profiles), 0, None) to add a topic.
        self._queue: collections.deque = collections.deque()
        self._drain_period = p.drain_period
        self._reorder_window_ns = round(p.reorder_window * 1e9)
        self._batched: set[int] = set()   # topic indexes recorded from their batches (module docstring)
        self._deduplicated: set[int] = set()   # topic indexes read both ways: a sample's second copy is dropped
        self._duplicates = 0
        self._out_of_order = 0   # samples written before one with a later time (a batch later than reorder_window)
        # The node whose subscriptions the taker thread takes from (module docstring); None: the executor's path.
        self._reader = None if self._count_lost else Node(
            f"{self.get_name()}_reader", namespace=self.get_namespace(), context=self.context,
            use_global_arguments=False, enable_rosout=False, start_parameter_services=False)
        # (topic index, subscription, BATCH or None) the taker thread takes from
        self._taken: list[tuple[int, object, object]] = []
        self._topic_names: list[str] = []
        self._channel_ids: list[int] = []  # MCAP channel id per topic index (writer thread)
        self._recorded: dict[str, object] = {}
        self._also_read: list[object] = []   # the direct subscriptions of topics also read from batches
        self._types: dict[str, str] = {}             # topic -> its type name
        self._direct_qos: dict[str, QoSProfile] = {}  # topic -> the QoS it is (or would be) read with directly
        self._skipped: set[str] = set()
        self._counts: list[int] = []
        self._lost: dict[str, int] = {}  # topic -> DDS message-lost total (executor thread)
        self._max_backlog = 0
        self._stop = threading.Event()
        self._finish_lock = threading.Lock()
        self._finished = False
        self._writer_error: BaseException | None = None
        self._taker = threading.Thread(target=self._take_loop, name="bag_taker", daemon=True) \
            if self._reader is not None else None
        self._writer = threading.Thread(target=self._write_loop, name="bag_writer", daemon=True)
        self._writer.start()
        if self._taker is not None:
            self._taker.start()

        self._status_publisher = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        # Discovery on the wall clock: under simulated time the lockstep simulation stands at t = 0 until the
        # replica answers, and a sim-time timer would not look for topics until it moved on (the first 0.6 s of
        # /joint_states of a lockstep run were missed that way).
        self.create_timer(p.discovery_period, self._discover,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.create_timer(p.status_period, self._publish_status)
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
            if RECORD_BATCH_TYPE in types or topic in self._skipped or not self._wanted(topic):
                continue    # batches are unpacked into their topics, never recorded as such
            if topic not in self._recorded:
                self._subscribe(topic, types)
        for index in self._batched - self._deduplicated:
            self._check_batched(index)

    def _batching_nodes(self, topic: str) -> set[tuple[str, str]]:
        return {(info.node_namespace, info.node_name)
                for info in self.get_publishers_info_by_topic(record_topic(topic))
                if info.topic_type == RECORD_BATCH_TYPE}

    def _check_batched(self, index: int) -> None:
        """A topic recorded from its batches that gained a publisher without them: the topic is read message by
        message as well, and since the batching publishers then publish it too (it has a reader), a sample that comes
        both ways is written once (the writer compares the bytes of the topic's samples of the last
        ``DUPLICATE_WINDOW_NS``); one warning."""
        topic = self._topic_names[index]
        others = ({(info.node_namespace, info.node_name) for info in self.get_publishers_info_by_topic(topic)}
                  - self._batching_nodes(topic))
        if not others:
            return
        self.get_logger().warning(
            f"{topic}: recorded from its batches, but {', '.join(name for _, name in sorted(others))} publishes it "
            f"without: recording its messages one by one as well")
        self._deduplicated.add(index)
        self._also_read.append(self._subscribe_to(index, topic, message_class(self._types[topic]),
                                                  self._direct_qos[topic]))

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
        self._types[topic], self._direct_qos[topic] = type_name, qos
        # The bag learns the topic before its first message: the queue is FIFO.
        self._queue.append((None, (topic, type_name, offered), 0, None))
        publishing = {(p.node_namespace, p.node_name) for p in publishers}
        batching = self._batching_nodes(topic)
        if publishing <= batching:   # every publisher also sends batches: take those instead
            self._batched.add(index)
            batch_qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=self._queue_depth,
                                   reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
            self._recorded[topic] = self._subscribe_to(index, record_topic(topic), message_class(RECORD_BATCH_TYPE),
                                                       batch_qos, batches=True)
            self.get_logger().info(f"recording {topic} [{type_name}] from its batches on {record_topic(topic)}")
            return
        self._recorded[topic] = self._subscribe_to(index, topic, subscription_type, qos)
        self.get_logger().info(f"recording {topic} [{type_name}] "
                               f"({qos.reliability.name.lower()}, {qos.durability.name.lower()}, depth {qos.depth})")

    def _subscribe_to(self, index: int, topic: str, subscription_type: type, qos: QoSProfile, batches: bool = False):
        """A raw subscription whose messages (``batches``: whose batches' samples) go to the bag as topic
        ``index``'s."""
        kind = BATCH if batches else None
        if self._reader is not None:
            subscription = self._reader.create_subscription(subscription_type, topic, _never_called, qos, raw=True)
            self._taken.append((index, subscription, kind))
            return subscription
        return self.create_subscription(
            subscription_type, topic, self._enqueuer(index, kind), qos, raw=True,
            event_callbacks=SubscriptionEventCallbacks(message_lost=self._lost_counter(topic)))

    def _enqueuer(self, index: int, kind: object):
        # One argument only: rclpy takes a callback that also accepts a second argument for a MessageInfo
        # callback, which the EventsExecutor cannot serve (a default argument would trip that check).
        append, now = self._queue.append, time.time_ns

        def enqueue(data: bytes) -> None:
            append((index, data, now(), kind))
        return enqueue

    def _lost_counter(self, topic: str):
        def count(status) -> None:
            self._lost[topic] = int(status.total_count)
            self.get_logger().warning(f"{topic}: DDS lost {status.total_count_change} message(s) before this "
                                      f"recorder took them ({status.total_count} in all); a writer's history is "
                                      f"shorter than this recorder's stall", throttle_duration_sec=1.0)
        return count

    def lost(self) -> dict[str, int] | None:
        """DDS message-lost totals per topic (topics that lost none are left out); None: not counted."""
        if not self._count_lost:
            return None
        return {topic: count for topic, count in sorted(self._lost.items()) if count}

    # -- writing (writer thread) ------------------------------------------------------------------------------
    def _take_loop(self) -> None:
        """The taker thread: every ``drain_period``, what each subscription holds, in order of arrival, onto the
        queue; a last round once asked to stop (finish), then the writer is told it may stop."""
        append = self._queue.append
        try:
            while True:
                stopping = self._stop.is_set()
                taken = []
                for index, subscription, kind in list(self._taken):
                    take = subscription.handle.take_message
                    while (item := take(subscription.msg_type, True)) is not None:
                        data, info = item
                        taken.append((index, data, info["received_timestamp"],
                                      info["source_timestamp"] if kind is None else kind))
                taken.sort(key=lambda row: row[2])
                for row in taken:
                    append(row)
                if stopping:
                    return
                time.sleep(self._drain_period)
        except BaseException as error:  # the executor thread reports it; recording cannot go on
            self._writer_error = error
            raise

    def _write_loop(self) -> None:
        queue, bag, counts, live = self._queue, self.bag, self._counts, self.live
        # Messages held for the reorder window, oldest first: (log time, arrival number, topic index, cdr, publish
        # time); the arrival number keeps a topic's messages of one time in order and never compares the rest.
        held: list[tuple[int, int, int, bytes, int | None]] = []
        arrival = itertools.count()
        last_written = 0
        seen: dict[int, dict[bytes, int]] = {}   # the samples written lately of each deduplicated topic -> time
        try:
            while True:
                # The taker's last round is in the queue once it has ended (finish joins it before the writer).
                stopping = self._stop.is_set() and (self._taker is None or not self._taker.is_alive())
                backlog = len(queue)
                self._max_backlog = max(self._max_backlog, backlog)
                while queue:
                    index, data, stamp, published = queue.popleft()
                    if index is None:
                        self._add_topic(*data)
                    elif published is BATCH:
                        for when, sample in unpack(data)[1]:
                            heapq.heappush(held, (when, next(arrival), index, sample, when))
                    else:
                        heapq.heappush(held, (stamp, next(arrival), index, data, published))
                # Without batched topics nothing waits: every message taken is older than now.
                horizon = time.time_ns() - (self._reorder_window_ns if self._batched else 0)
                while held and (stopping or held[0][0] <= horizon):
                    stamp, _, index, data, published = heapq.heappop(held)
                    if index in self._deduplicated and self._seen_before(seen.setdefault(index, {}), data, stamp):
                        self._duplicates += 1
                        continue
                    if stamp < last_written:
                        self._out_of_order += 1
                    last_written = max(last_written, stamp)
                    bag.write(self._channel_ids[index], data, stamp, published)
                    counts[index] += 1
                    if live is not None:
                        live.offer(self._topic_names[index], data, stamp)
                    if self._topic_names[index] == self._joint_states_topic:
                        self.joint_states.add(data)
                if stopping:
                    return
                if not bag.maybe_flush():   # the taker's pace (a round a drain_period); the executor's 2 ms
                    time.sleep(self._drain_period if self._taker is not None else 0.002)
        except BaseException as error:  # the executor thread reports it; recording cannot go on
            self._writer_error = error
            raise

    @staticmethod
    def _seen_before(seen: dict[bytes, int], data: bytes, stamp: int) -> bool:
        """Whether these bytes were written within DUPLICATE_WINDOW_NS; remembered if not."""
        if data in seen and stamp - seen[data] <= DUPLICATE_WINDOW_NS:
            return True
        seen[data] = stamp
        if len(seen) > 50_000:   # a minute at 1 kHz: forget what is older than the window
            for old in [key for key, when in seen.items() if stamp - when > DUPLICATE_WINDOW_NS]:
                del seen[old]
        return False

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
        lost = self.lost()
        if lost:
            status.level = DiagnosticStatus.WARN
            status.message += f"; DDS lost {sum(lost.values())} messages"
        values = {"bag": str(self.bag.bag_dir), "backlog": len(self._queue), "max_backlog": self._max_backlog,
                  "joint_states_received": self.joint_states.received,
                  "joint_states_dropped": self.joint_states.dropped,
                  "joint_states_out_of_order": self.joint_states.out_of_order,
                  "joint_states_off_step_grid": self.joint_states.off_grid,
                  "lost_messages": "not counted" if lost is None else sum(lost.values()),
                  "batched_topics": ",".join(self._topic_names[index] for index in sorted(self._batched)),
                  "written_out_of_time_order": self._out_of_order,
                  "duplicates_dropped": self._duplicates}
        values.update({f"count {topic}": count for topic, count in self.counts().items()})
        values.update({f"lost {topic}": count for topic, count in (lost or {}).items()})
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
            if self._reader is None:
                for subscription in [*self._recorded.values(), *self._also_read]:
                    self.destroy_subscription(subscription)
            self._stop.set()
            if self._taker is not None:
                self._taker.join()    # its last round takes what the subscriptions still hold
            self._writer.join()
            if self._reader is not None:
                self._reader.destroy_node()
            lost = self.lost()
            summary = self.bag.finish(custom_data=None if lost is None else {"lost_messages": json.dumps(lost)})
            if self.live is not None:
                self.live.stop()
            per_topic = ", ".join(f"{topic} {count}" for topic, count in sorted(summary.topics.items()))
            self._log_info(
                f"finished bag {summary.bag_dir.resolve()}: {summary.message_count} messages on "
                f"{len(summary.topics)} topics ({per_topic}); {self._joint_states_topic}: "
                f"{self.joint_states.received} received, {self.joint_states.dropped} dropped in "
                f"{self.joint_states.gaps} gaps, {self.joint_states.out_of_order} out of order, "
                f"{self.joint_states.off_grid} off the step grid (not gap-checked); "
                f"max backlog {self._max_backlog}; {self._out_of_order} written out of time order, "
                f"{self._duplicates} second copies dropped; DDS lost "
                + ("(not counted)" if lost is None else
                   ", ".join(f"{topic} {count}" for topic, count in lost.items()) if lost else "none"))


#: How far apart two copies of one sample can reach the writer (a batch's and the topic's own) [ns].
DUPLICATE_WINDOW_NS = 5_000_000_000

#: The mark of a queued message that is a batch of samples (fic_teleop_runtime.record_batch), in place of its publish
#: time.
BATCH = object()


def _never_called(_data: bytes) -> None:
    """The callback of a subscription no executor spins (the writer thread takes its messages)."""


def main(args: list[str] | None = None) -> None:
    # Spin in bounded slices of 0.5 s on the EventsExecutor even under simulated time: the recorder's timers need
    # not land on simulated time, and it takes every 1 kHz stream (fic_teleop_runtime.spin). The bag is finished
    # after the spin, with a second Ctrl-C ignored so it cannot cut the footer (fic_teleop_runtime.node_main).
    run_entry(ENTRY, args)


def _finish(node: RecorderNode) -> None:
    node.finish()


ENTRY = NodeEntry(RecorderNode, "recorder", refusals=(BagError, LiveViewError), stopped=_finish, slice_s=0.5,
                  follow_sim_time=False)


if __name__ == "__main__":
    main()
