"""A stream's samples carried to the recorder many to a message, every sample kept.

Why: the graph's fast streams (the joint states and the F/T wrench at the physics rate, the torque command, the
haptic pose and the force command: 2,500 messages a second) went to the recorder one DDS message each. Each cost the
publisher a delivery to one more reader and the recorder a receive and a take, about 64 us a message on this machine
kind, a tenth of the main job's CPU (docs/RESULTS.md, "Benches"). A ``BatchedPublisher`` serialises each sample once
and publishes those bytes on the topic itself only while it has a reader there (the master reading /haptic/pose, a
``ros2 topic echo``, a replica in another process), and appends them to a ``RecordBatch`` on ``record_topic(topic)``
(``/record/joint_states`` for ``/joint_states``), published once ``batch_period`` has gone by. The recorder takes the
batch and writes each sample into the bag under the original topic with its publication time, so a bag holds the
same messages as before and nothing that reads a bag changes (fic_teleop_tools/recording/recorder_node.py).

One limit of rmw_fastrtps's serialisation (what rclpy's ``serialize_message`` calls): it reports the estimated length,
which exceeds the CDR when a sequence of 8-byte numbers is empty (a JointState without velocities: 5 bytes more,
garbage). ROS readers ignore the tail; a reader that checks the length (rosbags) refuses the sample. The five batched
streams never have an empty one (test/runtime/test_record_batch.py keeps both facts in sight).

What it costs: a sample reaches the bag up to ``batch_period`` later (the recorder holds every message for a reorder
window longer than that, so the bag stays in time order), and a publisher killed by SIGKILL takes its unsent batch
with it (a stop by signal sends it: ``flush_node`` runs before the node is destroyed).
"""
from __future__ import annotations

import itertools
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message, serialize_message

from fic_teleop_msgs.msg import RecordBatch
from fic_teleop_runtime import qos as graph_qos

#: Where a topic's batches go: ``/record`` before the topic's own name.
RECORD_PREFIX = "/record"
#: The type the recorder recognises batches by (never recorded as such).
RECORD_BATCH_TYPE = "fic_teleop_msgs/msg/RecordBatch"


def record_topic(topic: str) -> str:
    """The topic ``topic``'s batches are published on."""
    return RECORD_PREFIX + (topic if topic.startswith("/") else "/" + topic)


def stream_readers(node: Node, topic: str) -> int:
    """The readers of a stream in either form, as the graph shows them to ``node``: of the topic and of its batches
    (a recorder)."""
    return node.count_subscribers(topic) + node.count_subscribers(record_topic(topic))


def type_name(message_type: type) -> str:
    """``package/msg/Name`` of a generated message class."""
    return f"{message_type.__module__.split('.')[0]}/msg/{message_type.__name__}"


def unpack(data: bytes) -> tuple[str, Iterator[tuple[int, bytes]]]:
    """A serialised RecordBatch: its topic, and (publication time ns, sample CDR bytes) for each sample."""
    batch = deserialize_message(data, RecordBatch)
    payload = batch.data.tobytes()
    starts = itertools.chain((0,), batch.ends)
    return batch.topic, ((int(when), payload[start:end])
                         for when, start, end in zip(batch.publish_times, starts, batch.ends))


class BatchedPublisher:
    """A publisher of ``topic`` whose every sample also goes to the recorder in batches (module docstring).

    ``batch_period`` 0: a plain publisher (every sample on the topic, the recorder takes each). ``publish`` may be
    called from any thread; one lock keeps a batch whole against ``flush`` at the stop."""

    def __init__(self, node: Node, message_type: type, topic: str, qos: QoSProfile, batch_period: float) -> None:
        self.topic = node.resolve_topic_name(topic)
        self.batch_period_ns = round(batch_period * 1e9)
        # The batch publisher first: a recorder that discovers the topic's publisher finds its batches' too
        # (a participant announces its writers in the order they are made).
        self._batches = (node.create_publisher(RecordBatch, record_topic(self.topic), graph_qos.RECORD_BATCH)
                         if self.batch_period_ns > 0 else None)
        self._live = node.create_publisher(message_type, topic, qos)
        self._type = type_name(message_type)
        self._lock = threading.Lock()
        self._times: list[int] = []
        self._samples: list[bytes] = []
        self.batches_sent = 0
        if self._batches is not None:
            _NODES.setdefault(node, []).append(self)

    def reader_count(self) -> int:
        """The stream's readers in either form: on the topic itself and on its batches (the recorder)."""
        batch_readers = 0 if self._batches is None else self._batches.get_subscription_count()
        return self._live.get_subscription_count() + batch_readers

    def publish(self, message: Any) -> None:
        if self._batches is None:
            self._live.publish(message)
            return
        data = serialize_message(message)
        if self._live.get_subscription_count():
            self._live.publish(data)   # the same bytes: serialised once
        now = time.time_ns()
        with self._lock:
            self._times.append(now)
            self._samples.append(data)
            due = now - self._times[0] >= self.batch_period_ns
        if due:
            self.flush()

    def pending(self) -> int:
        """Samples waiting for the next batch."""
        with self._lock:
            return len(self._samples)

    def flush(self) -> None:
        """Publish what the current batch holds (nothing: nothing sent)."""
        with self._lock:
            if not self._samples:
                return
            times, samples = self._times, self._samples
            self._times, self._samples = [], []
        self._batches.publish(RecordBatch(topic=self.topic, type=self._type, publish_times=times,
                                          ends=list(itertools.accumulate(map(len, samples))),
                                          data=b"".join(samples)))
        self.batches_sent += 1


#: The batched publishers of each node, so that the node's stop sends their last batches (node_main).
_NODES: dict[Node, list[BatchedPublisher]] = {}


def flush_node(node: Node) -> None:
    """Send the last batch of every batched publisher of ``node``; before the node is destroyed. Not waited for: DDS
    sends it before publish returns (rmw_fastrtps publishes synchronously), while its acknowledgement waits for the
    writer's next heartbeat, 0.6-2 s here, which made every stop of the main job 2 s longer. A context already shut
    down (an external shutdown) cannot send: one line names the samples lost."""
    for publisher in _NODES.pop(node, []):
        pending = publisher.pending()
        try:
            publisher.flush()
        except Exception as error:  # noqa: BLE001 - rclpy raises several types on a dead context
            print(f"[WARN] [{node.get_name()}]: the last {pending} samples of {publisher.topic} did not reach the "
                  f"recorder: {error}", file=sys.stderr, flush=True)
