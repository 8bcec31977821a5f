"""The recorder takes a stream from its batches (fic_teleop_runtime/record_batch.py) as a real process over DDS.

A publisher process sends /joint_states at 1 kHz through a BatchedPublisher (50 ms a batch) and /replica/fic_state at
100 Hz plainly, then stops its node as the node runtime does (the last batch sent); the recorder is
stopped with SIGINT and the bag is read back with rosbags: every joint state once, in order, under /joint_states with
its type, nothing under /record/..., the file in time order. With a second, plain publisher of /joint_states the
recorder takes the topic message by message instead, and no sample is lost.
"""
from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.nodes

PUBLISHER = r'''
import sys, time
import rclpy
from sensor_msgs.msg import JointState
from fic_teleop_msgs.msg import FicState
from fic_teleop_runtime import qos
from fic_teleop_runtime.record_batch import BatchedPublisher, flush_node

count, name, period = int(sys.argv[1]), sys.argv[2], float(sys.argv[3])
first = int(sys.argv[4])          # this publisher's first stamp (ms): two publishers never share one
rclpy.init()
node = rclpy.create_node(name)
joint_states = BatchedPublisher(node, JointState, "/joint_states", qos.ROBOT_STREAM, period)
fic = node.create_publisher(FicState, "/replica/fic_state", qos.STREAM_WRITER)
deadline = time.monotonic() + 30.0
while joint_states.reader_count() < 1 or fic.get_subscription_count() < 1:
    if time.monotonic() > deadline:
        sys.exit("the recorder never subscribed")
    time.sleep(0.02)
print("matched", flush=True)
time.sleep(float(sys.argv[5]))    # until the other publisher, if any, is matched too
message = JointState(name=[f"panda_joint{i + 1}" for i in range(7)])
start = time.monotonic()
for k in range(count):
    wait = start + k * 0.001 - time.monotonic()
    if wait > 0.0:
        time.sleep(wait)
    stamp = first + k
    message.header.stamp.sec, message.header.stamp.nanosec = 100 + stamp // 1000, (stamp % 1000) * 1_000_000
    message.position = [stamp * 1e-3 + j for j in range(7)]
    message.velocity = message.effort = [0.5] * 7   # as the robot's (record_batch.py: an empty one pads the length)
    joint_states.publish(message)
    if k % 10 == 0:
        f = FicState(controller="fic", total_energy=float(stamp))
        f.header.stamp = message.header.stamp
        fic.publish(f)
flush_node(node)                  # the node runtime's stop: the last batch out
print(f"published {count} in {joint_states.batches_sent} batches", flush=True)
node.destroy_node()
rclpy.shutdown()
'''


def _publish(tmp_path: Path, env: dict, count: int, name: str, period: float, first: int,
             pause: float) -> subprocess.Popen:
    script = tmp_path / "batched_publisher.py"
    script.write_text(PUBLISHER)
    log = open(tmp_path / f"{name}.log", "wb")
    return subprocess.Popen([sys.executable, str(script), str(count), name, str(period), str(first), str(pause)],
                            env=env, stdout=log, stderr=subprocess.STDOUT)


def _output(tmp_path: Path, name: str) -> str:
    return (tmp_path / f"{name}.log").read_text(errors="replace")


def _joint_stamps(bag: Path) -> tuple[list[int], dict[str, str], list[int]]:
    """The /joint_states header stamps in file order, every topic's type, and every message's log time in file
    order."""
    from rosbags.highlevel import AnyReader

    with AnyReader([bag]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        stamps = []
        for connection, _, raw in reader.messages(connections=[c for c in reader.connections
                                                               if c.topic == "/joint_states"]):
            message = reader.deserialize(raw, connection.msgtype)
            stamps.append(message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec)
    from mcap.reader import make_reader
    with open(next(bag.glob("*.mcap")), "rb") as stream:
        log_times = [m.log_time for _, _, m in make_reader(stream).iter_messages(log_time_order=False)]
    return stamps, types, log_times


def _stamps(first: int, count: int) -> list[int]:
    return [(100 + s // 1000) * 1_000_000_000 + (s % 1000) * 1_000_000 for s in range(first, first + count)]


def test_a_batched_stream_is_recorded_under_its_own_topic_every_sample_once_in_order(start_node, tmp_path,
                                                                                    ros_env):
    bag = tmp_path / "bag"
    recorder = start_node("fic_teleop_tools", "recorder_node",
                          params={"bag_path": str(bag), "topics": ["/joint_states", "/replica/fic_state"]})
    publisher = _publish(tmp_path, ros_env, 2000, "batcher", 0.05, 0, 0.0)
    assert publisher.wait(timeout=60) == 0, _output(tmp_path, "batcher") + recorder.output()
    batches = int(_output(tmp_path, "batcher").split("published 2000 in ")[1].split()[0])
    assert 30 <= batches <= 41   # 2 s of samples, a batch each 50 ms (fewer when the publisher ran late), the rest
    recorder.process.send_signal(signal.SIGINT)
    assert recorder.process.wait(timeout=20) == 0, recorder.output()
    log = recorder.output()
    assert "recording /joint_states [sensor_msgs/msg/JointState] from its batches on /record/joint_states" in log

    stamps, types, log_times = _joint_stamps(bag)
    assert stamps == _stamps(0, 2000), log    # all, once, in order
    assert types == {"/joint_states": "sensor_msgs/msg/JointState",
                     "/replica/fic_state": "fic_teleop_msgs/msg/FicState"}   # no /record/... topic
    assert log_times == sorted(log_times)     # held for the reorder window: the file in time order
    assert "0 written out of time order" in log and "/joint_states: 2000 received, 0 dropped" in log


@pytest.mark.parametrize("count_lost_messages", [False, True])   # the taker's path and the executor's
def test_a_topic_with_a_publisher_that_does_not_batch_is_recorded_message_by_message(start_node, tmp_path, ros_env,
                                                                                    count_lost_messages):
    bag = tmp_path / "bag"
    recorder = start_node("fic_teleop_tools", "recorder_node",
                          params={"bag_path": str(bag), "topics": ["/joint_states", "/replica/fic_state"],
                                  "joint_states_period": 0.001, "count_lost_messages": count_lost_messages})
    # The batching publisher first: the recorder takes /joint_states from its batches; then a plain one joins.
    batcher = _publish(tmp_path, ros_env, 1000, "batcher", 0.05, 0, 6.0)
    deadline = time.monotonic() + 30.0
    while "from its batches on /record/joint_states" not in recorder.output() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert "from its batches on /record/joint_states" in recorder.output(), recorder.output()
    plain = _publish(tmp_path, ros_env, 1000, "plain", 0.0, 5000, 1.0)
    for process, name in ((batcher, "batcher"), (plain, "plain")):
        assert process.wait(timeout=60) == 0, _output(tmp_path, name) + recorder.output()
    recorder.process.send_signal(signal.SIGINT)
    assert recorder.process.wait(timeout=20) == 0, recorder.output()

    # The recorder read the topic message by message as well once the plain one came, and wrote every sample of
    # each publisher once (the batching one's came both ways).
    assert "recording its messages one by one as well" in recorder.output(), recorder.output()
    stamps, _, _ = _joint_stamps(bag)
    assert sorted(stamps) == _stamps(0, 1000) + _stamps(5000, 1000), (len(stamps), recorder.output())
    assert len(stamps) == 2000
    dropped = int(recorder.output().split(" second copies dropped")[0].rsplit(" ", 1)[1])
    assert dropped > 0   # the batching publisher's samples did come both ways, and one copy of each was kept
