"""A finished bag read from its indexes (bag_reader.read_indexed) gives what the sequential reader gives: every topic's
receive times in file order and the asked topics' messages; a torn bag (no summary) is left to the sequential
reader. The launcher's one pass (run_bag.scan) and the two-station analysis (station_analysis.read_bag) take the
indexed read when they can and give the same figures either way."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rclpy.serialization import serialize_message

from fic_teleop_tools.recording import bag_reader
from fic_teleop_tools.recording.bag_reader import read_indexed, read_messages
from fic_teleop_tools.recording.bag_writer import BagWriter

START_NS = 1_700_000_000_000_000_000


def _write(bag: Path, finish: bool = True) -> None:
    """Four topics at 500, 250, 100 and 10 Hz for 2 s, with receive times that are not in stamp order across topics
    (a late /clock), in 4 kB chunks: many chunks, each holding several topics."""
    from builtin_interfaces.msg import Time
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    writer = BagWriter(bag, chunk_size=4096)
    writer.add_topic("/joint_states", "sensor_msgs/msg/JointState")
    writer.add_topic("/clock", "rosgraph_msgs/msg/Clock")
    writer.add_topic("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray")
    writer.add_topic("/unused", "sensor_msgs/msg/JointState")   # a channel with no message
    rng = np.random.default_rng(7)
    for k in range(1000):
        now = START_NS + k * 2_000_000
        writer.write("/joint_states", serialize_message(JointState(name=["j1"], position=[0.001 * k])),
                     now + int(rng.integers(0, 500_000)))
        if k % 5 == 0:
            clock = Clock(clock=Time(sec=k // 500, nanosec=(k % 500) * 2_000_000))
            writer.write("/clock", serialize_message(clock), now - int(rng.integers(0, 3_000_000)))
        if k % 50 == 0:
            status = DiagnosticStatus(name="replica" if k % 100 else "master",
                                      values=[KeyValue(key="ticks", value=str(k))])
            writer.write("/diagnostics", serialize_message(DiagnosticArray(status=[status])), now + 1)
    if finish:
        writer.finish()


@pytest.fixture(scope="module")
def bag(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("indexed") / "bag"
    _write(path)
    return path


def _sequential(bag: Path) -> tuple[dict[str, list[int]], dict[str, list[tuple[int, bytes]]]]:
    times: dict[str, list[int]] = {}
    data: dict[str, list[tuple[int, bytes]]] = {}
    for _, channel, message in read_messages(bag):
        times.setdefault(channel.topic, []).append(message.log_time)
        data.setdefault(channel.topic, []).append((message.log_time, bytes(message.data)))
    return times, data


def test_the_indexes_give_every_topics_times_and_the_asked_messages_as_the_sequential_reader(bag: Path) -> None:
    times, data = _sequential(bag)
    indexed = read_indexed(bag, {"/clock", "/diagnostics"})
    assert indexed is not None
    assert set(indexed.receive_times) == set(times) == {"/joint_states", "/clock", "/diagnostics"}
    for topic, expected in times.items():
        assert indexed.receive_times[topic].dtype == np.int64
        assert indexed.receive_times[topic].tolist() == expected, topic   # exact nanoseconds, file order
    assert set(indexed.payloads) == {"/clock", "/diagnostics"}
    for topic in indexed.payloads:
        assert [(log, bytes(cdr)) for log, cdr in indexed.payloads[topic]] == data[topic], topic


def test_a_torn_bag_is_left_to_the_sequential_reader(tmp_path: Path) -> None:
    torn = tmp_path / "torn"
    _write(torn, finish=False)
    assert read_indexed(torn, {"/clock"}) is None
    assert read_indexed(tmp_path / "missing", set()) is None


def test_the_launchers_pass_gives_the_same_figures_from_the_indexes(bag: Path, monkeypatch) -> None:
    from fic_teleop_bringup.run_bag import scan

    topics, statuses = {"/joint_states", "/missing"}, {"replica": "ticks", "master": "ticks", "absent": "x"}
    from_indexes = scan(bag, topics, statuses)
    monkeypatch.setattr(bag_reader, "read_indexed", lambda *_: None)
    sequential = scan(bag, topics, statuses)
    assert from_indexes.receive_times == sequential.receive_times and set(sequential.receive_times) == {"/joint_states"}
    assert from_indexes.span == sequential.span and from_indexes.span[0] < START_NS   # the late /clock's time
    assert np.array_equal(from_indexes.clock_stamps, sequential.clock_stamps) and len(sequential.clock_stamps) == 200
    assert from_indexes.diagnostics == sequential.diagnostics == {"replica": {"ticks": "950"},
                                                                    "master": {"ticks": "900"}}
    assert from_indexes.error == sequential.error == ""


def test_the_station_analysis_reads_the_same_times_and_messages_from_the_indexes(bag: Path, monkeypatch) -> None:
    from fic_teleop_bringup.station_analysis import read_bag

    from_indexes = read_bag(bag, {"/diagnostics"})
    monkeypatch.setattr(bag_reader, "read_indexed", lambda *_: None)
    sequential = read_bag(bag, {"/diagnostics"})
    assert from_indexes["logs"].keys() == sequential["logs"].keys()
    for topic, logs in sequential["logs"].items():
        assert np.array_equal(from_indexes["logs"][topic], logs), topic
    assert [log for log, _ in from_indexes["messages"]["/diagnostics"]] == \
        [log for log, _ in sequential["messages"]["/diagnostics"]]
    assert [m.status[0].values[0].value for _, m in from_indexes["messages"]["/diagnostics"]] == \
        [m.status[0].values[0].value for _, m in sequential["messages"]["/diagnostics"]]
