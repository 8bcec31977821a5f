"""What the launcher reads of a finished run's bag, in one pass: the loops' receive times, the /clock stamps and the
last /diagnostics record of each status it judges.

The timing verdict (launch_timing.py) needs the first two, the safety verdict (launch_supervision.py) and the timing
verdict the third. Each read the whole bag on its own before (the loop rates, the clock stamps, the diagnostics
twice): four passes over some 100,000 messages, 1.7 CPU-s after every 30 s run, against 0.6 for one pass. A
finished bag is now read from its indexes (bag_reader.read_indexed: the receive times without parsing a message,
/clock and /diagnostics from their chunks), about 0.05 CPU-s; a torn one (no summary) in the one pass.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

CLOCK_TOPIC = "/clock"
DIAGNOSTICS_TOPIC = "/diagnostics"


@dataclass
class RunBag:
    """One pass over a bag (``scan``). ``receive_times``: topic -> the recorder's receive times [ns] of the topics
    asked for; ``span``: the first and last receive time of any message (None: an empty bag); ``clock_stamps``: the
    simulation times [s] of /clock, and ``clock_receive_times`` their receive times [ns]; ``history``: status name ->
    every record of it that holds the key asked for, as key-values with its receive time [ns], in the bag's order;
    ``error``: why the read stopped early, if it did (a torn bag is read up to its last whole chunk)."""
    receive_times: dict[str, list[int]] = field(default_factory=dict)
    span: tuple[int, int] | None = None
    clock_stamps: np.ndarray = field(default_factory=lambda: np.zeros(0))
    clock_receive_times: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    history: dict[str, list[tuple[int, dict[str, str]]]] = field(default_factory=dict)
    error: str = ""

    @property
    def diagnostics(self) -> dict[str, dict[str, str]]:
        """Status name -> the key-values of its last record (as launch_supervision.diagnostics_records gives them)."""
        return {name: records[-1][1] for name, records in self.history.items()}


def _clock_seconds(cdr: bytes) -> float:
    """rosgraph_msgs/Clock in CDR: the 4-byte encapsulation header, then int32 sec and uint32 nanosec."""
    sec, nanosec = struct.unpack_from("<iI" if cdr[1] & 1 else ">iI", cdr, 4)
    return sec + 1e-9 * nanosec


def scan(bag: Path, topics: set[str], statuses: dict[str, str]) -> RunBag:
    """Read ``bag`` once: the receive times of ``topics``, the /clock stamps, and the last record of each status of
    ``statuses`` (status name -> a key its record must hold)."""
    from mcap_ros2.decoder import DecoderFactory

    from fic_teleop_tools.recording.bag_reader import ReadResult, read_indexed, read_messages

    indexed = read_indexed(bag, {CLOCK_TOPIC, DIAGNOSTICS_TOPIC})
    if indexed is not None:   # a finished bag: from its indexes, a tenth of the CPU of the pass below
        return _from_indexes(indexed, topics, statuses)
    result, run = ReadResult(), RunBag()
    times: dict[str, list[int]] = {topic: [] for topic in topics}
    clock: list[float] = []
    clock_times: list[int] = []
    first = last = None
    factory, decode = DecoderFactory(), None
    for schema, channel, message in read_messages(bag, result):
        log_time = message.log_time
        if first is None:
            first = last = log_time
        first, last = min(first, log_time), max(last, log_time)
        topic = channel.topic
        if topic in times:
            times[topic].append(log_time)
        if topic == CLOCK_TOPIC:
            clock.append(_clock_seconds(message.data))
            clock_times.append(log_time)
        elif topic == DIAGNOSTICS_TOPIC and schema is not None:
            decode = decode or factory.decoder_for(channel.message_encoding, schema)
            _records([(log_time, decode(message.data))], statuses, run)
    run.receive_times = {topic: stamps for topic, stamps in times.items() if stamps}
    run.span = (first, last) if first is not None else None
    run.clock_stamps = np.array(clock)
    run.clock_receive_times = np.array(clock_times, dtype=np.int64)
    run.error = result.stopped_by
    return run


def _records(timed_messages, statuses: dict[str, str], run: RunBag) -> None:
    """Each record of a status of ``statuses`` that holds its key, from (receive time, decoded /diagnostics) pairs,
    into ``run.history`` with its time."""
    for log_time, message in timed_messages:
        for status in message.status:
            if status.name in statuses:
                values = {item.key: item.value for item in status.values}
                if statuses[status.name] in values:
                    run.history.setdefault(status.name, []).append((int(log_time), values))


def _from_indexes(indexed, topics: set[str], statuses: dict[str, str]) -> RunBag:
    """`scan`'s RunBag from a bag_reader.read_indexed read (the same figures as its pass over every message)."""
    from mcap_ros2.decoder import DecoderFactory

    run = RunBag()
    run.receive_times = {topic: indexed.receive_times[topic].tolist() for topic in topics
                         if len(indexed.receive_times.get(topic, ()))}
    spans = [(times.min(), times.max()) for times in indexed.receive_times.values() if len(times)]
    run.span = (int(min(low for low, _ in spans)), int(max(high for _, high in spans))) if spans else None
    clock = indexed.payloads.get(CLOCK_TOPIC, [])
    run.clock_stamps = np.array([_clock_seconds(data) for _, data in clock])
    run.clock_receive_times = np.array([log_time for log_time, _ in clock], dtype=np.int64)
    _records(indexed.decoded(DIAGNOSTICS_TOPIC, DecoderFactory()) or [], statuses, run)
    return run
