"""The recorder node as a real process over DDS.

A publisher process sends /joint_states at 1 kHz with stamps 1 ms apart (a few stamps deliberately skipped, so
the gap count has something to find) and our own messages on four other topics; the recorder is stopped with
SIGINT or SIGTERM, or killed with SIGKILL, and the bag is read back with rosbags and mcap-ros2-support (and, for
the killed one, the mcap library's sequential reader on a pipe).
"""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

pytestmark = pytest.mark.nodes

PUBLISHER = r'''
import sys, time
import rclpy
from rclpy.duration import Duration
from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy
from sensor_msgs.msg import JointState
from geometry_msgs.msg import PoseStamped
from fic_teleop_msgs.msg import ChannelDelivery, FicState, LimitStatus

count, skip = int(sys.argv[1]), {int(s) for s in sys.argv[2].split(",") if s}
wait_for_acks = sys.argv[3] == "1"  # not when the test kills the recorder on purpose
writer_depth = int(sys.argv[4])
rclpy.init()
node = rclpy.create_node("test_publisher")
# Deep writer history: a reliable KEEP_LAST writer overwrites samples not yet acknowledged once its history is
# full, so on a starved machine a depth of 50 (50 ms at 1 kHz) can lose samples before they reach any reader.
qos = QoSProfile(depth=writer_depth, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
joint_states = node.create_publisher(JointState, "/joint_states", qos)
fic = node.create_publisher(FicState, "/replica/fic_state", qos)
limits = node.create_publisher(LimitStatus, "/replica/limit_status", qos)
deliveries = node.create_publisher(ChannelDelivery, "/channel/deliveries", qos)
pose = node.create_publisher(PoseStamped, "/replica/tcp_pose", qos)
publishers = [joint_states, fic, limits, deliveries, pose]
deadline = time.monotonic() + 30.0
# The recorder has matched every topic. No pause after it: a reliable writer keeps each sample for every reader
# it has matched until that reader acknowledges it, even one that has not yet matched the writer back, so
# nothing published from here on can be lost (the bag's checks below would show it).
while min(p.get_subscription_count() for p in publishers) < 1:
    if time.monotonic() > deadline:
        sys.exit("the recorder never subscribed")
    time.sleep(0.02)
print("matched", flush=True)
message = JointState()
message.name = [f"panda_joint{i + 1}" for i in range(7)]
start, published = time.monotonic(), 0
for k in range(count):
    wait = start + k * 0.001 - time.monotonic()  # paced on an absolute 1 ms grid, sleeping (no busy wait)
    if wait > 0.0:
        time.sleep(wait)
    stamp_sec, stamp_nanosec = 100 + k // 1000, (k % 1000) * 1_000_000
    if k not in skip:
        message.header.stamp.sec, message.header.stamp.nanosec = stamp_sec, stamp_nanosec
        message.position = [k * 1e-3 + j for j in range(7)]
        joint_states.publish(message)
        published += 1
    if k % 10 == 0:
        f = FicState(controller="fic", phase=[0, 1, 0, 1, 0, 1], error=[k * 1e-6] * 6, total_energy=float(k))
        f.header.stamp.sec, f.header.stamp.nanosec = stamp_sec, stamp_nanosec
        fic.publish(f)
        l = LimitStatus(shaping=1 if k % 20 == 0 else 0, ticks=k)
        l.header.stamp = f.header.stamp
        limits.publish(l)
        d = ChannelDelivery(topic="/replica/teleop_command", held=0.2)
        d.header.stamp = f.header.stamp
        deliveries.publish(d)
        p = PoseStamped()
        p.header.stamp, p.pose.position.x = f.header.stamp, k * 1e-3
        pose.publish(p)
    if k % 250 == 0:
        print(f"progress {published}", flush=True)
for publisher in publishers if wait_for_acks else []:  # the recorder has acknowledged every message
    if not publisher.wait_for_all_acked(Duration(seconds=30)):
        sys.exit(f"not acknowledged: {publisher.topic_name}")
print(f"published {published}", flush=True)
node.destroy_node()
rclpy.shutdown()
'''

RECORDED = {
    "/joint_states": "sensor_msgs/msg/JointState",
    "/replica/fic_state": "fic_teleop_msgs/msg/FicState",
    "/replica/limit_status": "fic_teleop_msgs/msg/LimitStatus",
    "/channel/deliveries": "fic_teleop_msgs/msg/ChannelDelivery",
    "/replica/tcp_pose": "geometry_msgs/msg/PoseStamped",
}
COUNT = 3000
SKIPPED = [1200, 1201, 1202, 2500]  # stamps the publisher leaves out: 4 "dropped" joint states


class Publisher:
    def __init__(self, tmp_path: Path, env: dict, count: int, skip: list[int], wait_for_acks: bool = True,
                 writer_depth: int = 1000) -> None:
        script = tmp_path / "publisher.py"
        script.write_text(PUBLISHER)
        self.log_path = tmp_path / "publisher.log"
        self._log = open(self.log_path, "wb")
        self.process = subprocess.Popen([sys.executable, str(script), str(count), ",".join(map(str, skip)),
                                         "1" if wait_for_acks else "0", str(writer_depth)],
                                        env=env, stdout=self._log, stderr=subprocess.STDOUT)

    def output(self) -> str:
        return self.log_path.read_text(errors="replace")

    def progress(self) -> int:
        lines = [line for line in self.output().splitlines() if line.startswith(("progress", "published"))]
        return int(lines[-1].split()[1]) if lines else 0

    def wait(self, timeout: float) -> int:
        try:
            return self.process.wait(timeout=timeout)
        finally:
            if self.process.poll() is None:
                self.process.kill()
                self.process.wait()
            self._log.close()


def _expected_joint_stamps(count: int, skip: list[int]) -> list[int]:
    return [(100 + k // 1000) * 1_000_000_000 + (k % 1000) * 1_000_000 for k in range(count) if k not in skip]


def _record(start_node, tmp_path, ros_env, params: dict, stop_signal: int):
    bag = tmp_path / "bag"
    recorder = start_node("fic_teleop_tools", "recorder_node", params={"bag_path": str(bag), **params})
    publisher = Publisher(tmp_path, ros_env, COUNT, SKIPPED)
    assert publisher.wait(timeout=40) == 0, publisher.output() + recorder.output()
    assert f"published {COUNT - len(SKIPPED)}" in publisher.output()
    recorder.process.send_signal(stop_signal)
    assert recorder.process.wait(timeout=20) == 0, recorder.output()
    return bag, recorder.output()


def _check_bag(bag: Path, recorder_log: str) -> None:
    from mcap_ros2.reader import read_ros2_messages
    from rosbags.highlevel import AnyReader

    expected_stamps = _expected_joint_stamps(COUNT, SKIPPED)
    mcap_files = list(bag.glob("*.mcap"))
    assert [f.name for f in mcap_files] == ["bag_0.mcap"]
    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert metadata["storage_identifier"] == "mcap" and metadata["relative_file_paths"] == ["bag_0.mcap"]
    counts = {t["topic_metadata"]["name"]: t["message_count"] for t in metadata["topics_with_message_count"]}
    assert counts["/joint_states"] == len(expected_stamps), recorder_log

    # rosbags, on the bag folder (metadata.yaml) and on the bare .mcap.
    for path in (bag, mcap_files[0]):
        with AnyReader([path]) as reader:
            types = {c.topic: c.msgtype for c in reader.connections}
            for topic, msgtype in RECORDED.items():
                assert types.get(topic) == msgtype, (topic, types)
            connections = [c for c in reader.connections if c.topic == "/joint_states"]
            stamps, positions = [], []
            for connection, _, raw in reader.messages(connections=connections):
                message = reader.deserialize(raw, connection.msgtype)
                stamps.append(message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec)
                positions.append(message.position)
            missing = sorted(set(expected_stamps) - set(stamps))
            assert stamps == expected_stamps, (len(stamps), missing[:20], recorder_log)  # all, once, in order
            k = np.array([(s - 100_000_000_000) // 1_000_000 for s in stamps])
            np.testing.assert_allclose(np.array(positions)[:, 3], k * 1e-3 + 3)
            fic = [reader.deserialize(raw, c.msgtype) for c, _, raw in
                   reader.messages(connections=[c for c in reader.connections if c.topic == "/replica/fic_state"])]
            assert len(fic) == COUNT // 10
            assert all(m.controller == "fic" and list(m.phase) == [0, 1, 0, 1, 0, 1] for m in fic)
            assert fic[7].total_energy == 70.0 and fic[7].error[2] == pytest.approx(70e-6)

    # mcap-ros2-support, decoding with the schemas stored in the file.
    by_topic: dict[str, list] = {}
    for item in read_ros2_messages(str(mcap_files[0])):
        assert item.schema.encoding == "ros2msg" and item.channel.message_encoding == "cdr"
        assert item.schema.name == RECORDED.get(item.channel.topic, item.schema.name)
        by_topic.setdefault(item.channel.topic, []).append(item.ros_msg)
    assert [m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec for m in by_topic["/joint_states"]] \
        == expected_stamps
    assert by_topic["/joint_states"][0].name == [f"panda_joint{i + 1}" for i in range(7)]
    assert [m.shaping for m in by_topic["/replica/limit_status"]] == [1 if k % 20 == 0 else 0
                                                                     for k in range(0, COUNT, 10)]
    assert {(m.topic, m.held) for m in by_topic["/channel/deliveries"]} == {("/replica/teleop_command", 0.2)}
    assert len(by_topic["/replica/tcp_pose"]) == COUNT // 10


def test_recorder_keeps_every_message_and_finishes_on_sigint(start_node, tmp_path, ros_env):
    bag, log = _record(start_node, tmp_path, ros_env, {"topics": list(RECORDED)}, signal.SIGINT)
    _check_bag(bag, log)
    # The gap counter found exactly the stamps the publisher skipped.
    assert f"/joint_states: {COUNT - len(SKIPPED)} received, {len(SKIPPED)} dropped in 2 gaps" in log, log
    # DDS's message-lost events are not counted by default (config/recorder.yaml, count_lost_messages): the bag
    # says so by having no count, rather than a count of none.
    assert "DDS lost (not counted)" in log, log
    custom = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]["custom_data"]
    assert "lost_messages" not in custom


def test_recorder_counts_what_dds_lost_while_it_was_stalled(start_node, tmp_path, ros_env):
    """A writer with a history of 1 and a recorder stopped (SIGSTOP) for 0.8 s at 1 kHz: DDS loses samples the
    writer no longer holds (here about 110-140 of them). The recorder's count of them (message-lost events) is in
    its log line, its bag's metadata.yaml and the report's metric, and accounts for every sample it did not
    record."""
    from fic_teleop_tools.report import ReportSettings, analyse, load_bag

    bag = tmp_path / "bag"
    recorder = start_node("fic_teleop_tools", "recorder_node", params={"bag_path": str(bag), "topics": list(RECORDED),
                                                                  "count_lost_messages": True})
    publisher = Publisher(tmp_path, ros_env, COUNT, [], writer_depth=1)
    deadline = time.monotonic() + 40
    while publisher.progress() < 1000 and time.monotonic() < deadline and publisher.process.poll() is None:
        time.sleep(0.02)
    assert publisher.progress() >= 1000, publisher.output() + recorder.output()
    recorder.process.send_signal(signal.SIGSTOP)
    time.sleep(0.8)
    recorder.process.send_signal(signal.SIGCONT)
    assert publisher.wait(timeout=40) == 0, publisher.output() + recorder.output()
    assert f"published {COUNT}" in publisher.output()
    recorder.process.send_signal(signal.SIGINT)
    assert recorder.process.wait(timeout=20) == 0, recorder.output()

    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    counts = {t["topic_metadata"]["name"]: t["message_count"] for t in metadata["topics_with_message_count"]}
    lost = json.loads(metadata["custom_data"]["lost_messages"])
    assert lost.get("/joint_states", 0) > 0, (lost, counts)           # the stall did lose samples ...
    assert counts["/joint_states"] + lost["/joint_states"] == COUNT, (lost, counts)  # ... and all are counted
    assert "DDS lost " in recorder.output() and f"/joint_states {lost['/joint_states']}" in recorder.output()
    metrics = analyse(load_bag(bag), ReportSettings()).metrics
    assert metrics["recorder_lost_messages"] == sum(lost.values())
    assert metrics["targets"]["recorder_lost_messages"]["met"] is False


def test_recorder_discovers_all_topics_and_finishes_on_sigterm(start_node, tmp_path, ros_env):
    bag, log = _record(start_node, tmp_path, ros_env, {"topics": ["/nothing"], "all": True}, signal.SIGTERM)
    _check_bag(bag, log)
    assert "finished bag" in log


def test_recorder_bag_survives_sigkill(start_node, tmp_path, ros_env):
    from mcap.exceptions import EndOfFile
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader

    from fic_teleop_tools.recording.recovery import recover
    from fic_teleop_tools.report import load_bag

    bag = tmp_path / "bag"
    recorder = start_node("fic_teleop_tools", "recorder_node",
                          params={"bag_path": str(bag), "topics": list(RECORDED), "flush_period": 0.2})
    publisher = Publisher(tmp_path, ros_env, 6000, [], wait_for_acks=False)
    deadline = time.monotonic() + 40
    while publisher.progress() < 2500 and time.monotonic() < deadline and publisher.process.poll() is None:
        time.sleep(0.02)
    published_before_kill = publisher.progress()
    assert published_before_kill >= 2500, publisher.output() + recorder.output()
    recorder.expected_returncode = -signal.SIGKILL  # killed on purpose: a torn bag
    recorder.process.send_signal(signal.SIGKILL)
    recorder.process.wait(timeout=10)
    publisher.wait(timeout=30)

    mcap_file = bag / "bag_0.mcap"
    # The mcap library, reading sequentially from a pipe (non-seekable), with CRC validation.
    cat = subprocess.Popen(["cat", str(mcap_file)], stdout=subprocess.PIPE)
    reader = make_reader(cat.stdout, validate_crcs=True, decoder_factories=[DecoderFactory()])
    stamps, ended_without_footer = [], False
    try:
        for _, _channel, _, message in reader.iter_decoded_messages(topics=["/joint_states"], log_time_order=False):
            stamps.append(message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec)
    except EndOfFile:
        ended_without_footer = True
    cat.wait()
    assert ended_without_footer  # the recorder really died before writing its footer
    assert not (bag / "metadata.yaml").exists()
    # Everything up to the last flush is there, in order, without a gap; the tail lost is the last flush period
    # plus what the recorder had not yet received (generous here: the machine may be busy).
    assert stamps == _expected_joint_stamps(len(stamps), [])
    assert len(stamps) >= published_before_kill - 1500, (len(stamps), published_before_kill, recorder.output())

    # recover() turns it into a complete bag that rosbags opens; the report reads the torn file directly.
    summary, result = recover(mcap_file, tmp_path / "recovered")
    assert not result.complete and summary.topics["/joint_states"] == len(stamps)
    with AnyReader([tmp_path / "recovered"]) as reader:
        assert {c.topic: c.msgcount for c in reader.connections}["/joint_states"] == len(stamps)
    data = load_bag(bag)
    assert not data.complete and data.counts["/joint_states"] == len(stamps)
