"""bag info / recover / play, on the project's bag reader and writer (fic_teleop_tools.recording)."""
from __future__ import annotations

import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import yaml
from mcap.exceptions import McapError
from mcap.reader import make_reader

from fic_core.errors import FicInputError
from fic_teleop_runtime.message_types import message_class
from fic_teleop_tools.cli.errors import CommandError
from fic_teleop_tools.recording.bag_reader import BagReadError, ReadResult, mcap_file, read_messages
from fic_teleop_tools.recording.bag_writer import BagError
from fic_teleop_tools.recording.recovery import recover

#: How long `bag play` waits in all, after the last message, for the reliable readers to acknowledge what they
#: were sent.
ACK_TIMEOUT_S = 10.0


def _existing_mcap(bag: str) -> Path:
    if not Path(bag).exists():
        raise CommandError(f"bag {bag} does not exist")
    try:
        return mcap_file(bag)
    except (BagError, BagReadError) as error:
        raise CommandError(f"{bag} is not a bag: {error}") from None


@dataclass
class BagSummaryView:
    path: Path
    start_ns: int
    end_ns: int
    message_count: int
    topics: list[tuple[str, str, int]]  # topic, type, count
    offered_qos: dict[str, str]  # topic -> the recorder's offered_qos_profiles (YAML)


def finished_summary(bag: str) -> BagSummaryView:
    """The summary a finished bag ends with; a torn bag (no summary) is a CommandError pointing to recover."""
    path = _existing_mcap(bag)
    try:
        with open(path, "rb") as stream:
            summary = make_reader(stream).get_summary()
    except (McapError, ValueError, EOFError, OSError) as error:
        summary, why = None, f"{type(error).__name__}: {error}"
    else:
        why = "no summary section"
    if summary is None or summary.statistics is None:
        result = ReadResult()
        readable = sum(1 for _ in read_messages(bag, result))
        raise CommandError(f"bag {bag} is torn ({why}; its recorder was stopped before finishing): {readable} "
                           f"messages readable; `scripts/fic bag recover {bag} <new bag>` rewrites them into a "
                           "complete bag")
    stats = summary.statistics
    topics = [(channel.topic, summary.schemas[channel.schema_id].name if channel.schema_id in summary.schemas else "",
               stats.channel_message_counts.get(channel_id, 0)) for channel_id, channel in summary.channels.items()]
    offered = {channel.topic: channel.metadata.get("offered_qos_profiles", "") for channel in summary.channels.values()}
    return BagSummaryView(path, stats.message_start_time, stats.message_end_time, stats.message_count,
                          sorted(topics), offered)


def bag_info(bag: str) -> int:
    view = finished_summary(bag)
    duration = max(0, view.end_ns - view.start_ns) * 1e-9
    size = view.path.stat().st_size
    print(f"Files:             {view.path.name}")
    print(f"Bag size:          {size / 2**20:.1f} MiB")
    print("Storage id:        mcap")
    print(f"Duration:          {duration:.3f}s")
    print(f"Start:             {time.strftime('%b %d %Y %H:%M:%S', time.localtime(view.start_ns * 1e-9))} "
          f"({view.start_ns * 1e-9:.9f})")
    print(f"End:               {time.strftime('%b %d %Y %H:%M:%S', time.localtime(view.end_ns * 1e-9))} "
          f"({view.end_ns * 1e-9:.9f})")
    print(f"Messages:          {view.message_count}")
    width = max((len(topic) for topic, _, _ in view.topics), default=0)
    for index, (topic, type_name, count) in enumerate(view.topics):
        label = "Topic information: " if index == 0 else " " * 19
        print(f"{label}Topic: {topic:<{width}} | Type: {type_name} | Count: {count} | Serialization Format: cdr")
    return 0


def bag_recover(source: str, destination: str) -> int:
    _existing_mcap(source)
    target = Path(destination)
    if target.exists() and any(target.iterdir()):
        raise CommandError(f"{destination} exists and is not empty; give a new bag folder")
    created = not target.exists()
    try:
        summary, result = recover(source, target)
    except BaseException as error:  # nothing half-written: a partial copy is worse than none
        if created:
            shutil.rmtree(target, ignore_errors=True)
        if isinstance(error, (BagError, BagReadError, OSError, McapError)):
            raise CommandError(f"cannot recover {source}: {error}") from None
        raise
    state = "was complete" if result.complete else f"was torn ({result.stopped_by})"
    print(f"{source} {state}: {summary.message_count} messages on {len(summary.topics)} topics written to "
          f"{summary.bag_dir}")
    return 0


def bag_play(bag: str, rate: float, topics: list[str] | None, wait_for_subscribers: float) -> int:
    """Publish the bag's messages on their topics (raw CDR, rclpy), paced by their receive times / `rate`."""
    if rate <= 0:
        raise CommandError(f"--rate must be > 0, got {rate:g}")
    view = finished_summary(bag)
    wanted = {topic: type_name for topic, type_name, _ in view.topics if topics is None or topic in topics}
    missing = sorted(set(topics or []) - set(wanted))
    if missing:
        raise CommandError(f"bag {bag} has no topic {', '.join(missing)}")
    classes = {}
    for topic, type_name in wanted.items():
        try:
            classes[topic] = message_class(type_name)
        except FicInputError as error:
            raise CommandError(f"cannot play {topic}: its type {type_name} is not installed here ({error})") from None

    import rclpy
    from rclpy.duration import Duration
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    from fic_teleop_tools.cli.graph import graph_node

    with graph_node("fic_bag_play") as node:
        publishers = {}
        for topic in wanted:
            offered = (yaml.safe_load(view.offered_qos[topic]) or [{}])[0]
            qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                             reliability=ReliabilityPolicy.BEST_EFFORT if offered.get("reliability") == "best_effort"
                             else ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL
                             if offered.get("durability") == "transient_local" else DurabilityPolicy.VOLATILE)
            publishers[topic] = node.create_publisher(classes[topic], topic, qos)
        deadline = time.monotonic() + wait_for_subscribers
        while time.monotonic() < deadline and any(p.get_subscription_count() == 0 for p in publishers.values()):
            rclpy.spin_once(node, timeout_sec=0.05)
        first_log = None
        wall_start = time.monotonic()
        played = late = 0
        result = ReadResult()
        for _, channel, message in read_messages(bag, result):
            publisher = publishers.get(channel.topic)
            if publisher is None:
                continue
            if first_log is None:
                first_log = message.log_time
            due = wall_start + (message.log_time - first_log) * 1e-9 / rate
            ahead = due - time.monotonic()
            if ahead > 0:
                time.sleep(ahead)
            elif ahead < -0.01:
                late += 1
            publisher.publish(message.data)
            played += 1
        wall = time.monotonic() - wall_start
        # Reliable readers have the last messages only once they acknowledged them: wait for that (a fixed pause
        # would lose the tail on a loaded machine), ACK_TIMEOUT_S in all (a dead reader costs it once, not once a
        # topic).
        ack_deadline = time.monotonic() + ACK_TIMEOUT_S
        unacknowledged = [topic for topic, publisher in publishers.items() if not publisher.wait_for_all_acked(
            Duration(seconds=max(0.0, ack_deadline - time.monotonic())))]
    print(f"played {played} messages on {len(publishers)} topics in {wall:.1f} s at rate {rate:g} "
          f"({late} more than 10 ms late)")
    if unacknowledged:
        print(f"warning: not acknowledged by every reader within {ACK_TIMEOUT_S:g} s: {', '.join(unacknowledged)}",
              file=sys.stderr)
    return 0

