"""dataset export / episode mark: recorded runs to a LeRobot dataset, and an episode's markers during a run."""
from __future__ import annotations

import re
import time

from fic_teleop_tools.cli.errors import CommandError

#: How long `episode mark` waits for a reader (the recorder) to acknowledge the mark.
ACK_TIMEOUT_S = 5.0


def parse_size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"(\d+)x(\d+)", text.strip())
    if not match:
        raise CommandError(f"--size must look like 640x480, got {text!r}")
    return int(match.group(1)), int(match.group(2))


def dataset_export(runs: list[str], out: str, fps: int | None, task: str | None, scene: str | None,
                   size: str) -> int:
    from fic_teleop_tools.dataset.export import DatasetError, export

    width, height = parse_size(size)
    started = time.monotonic()
    try:
        summary = export(runs, out, fps=fps, task=task, scene=scene, width=width, height=height)
    except DatasetError as error:
        raise CommandError(str(error)) from None
    print(f"[dataset] {len(summary.episodes)} episodes, {summary.frames} frames at {summary.fps} fps written to "
          f"{summary.root} (LeRobot v3.0) in {time.monotonic() - started:.0f} s"
          + (f"; left out: {', '.join(name for name, _ in summary.left_out)}" if summary.left_out else ""))
    return 0


def episode_mark(event: str, timeout: float) -> int:
    """Publish one episode marker where the running graph's recorder takes it."""
    from rclpy.duration import Duration
    from std_msgs.msg import String

    from fic_teleop_runtime.episode_markers import MARKER_TOPIC, MarkerError, checked_event
    from fic_teleop_runtime.qos import MARKERS
    from fic_teleop_tools.cli.graph import graph_node

    try:
        event = checked_event(event)
    except MarkerError as error:
        raise CommandError(str(error)) from None
    with graph_node("fic_episode_mark") as node:
        publisher = node.create_publisher(String, MARKER_TOPIC, MARKERS)
        deadline = time.monotonic() + timeout
        while publisher.get_subscription_count() == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        if publisher.get_subscription_count() == 0:
            raise CommandError(f"no reader of {MARKER_TOPIC} within {timeout:g} s: is a run with its recorder going "
                               "on this ROS_DOMAIN_ID?")
        publisher.publish(String(data=event))
        if not publisher.wait_for_all_acked(Duration(seconds=ACK_TIMEOUT_S)):
            raise CommandError(f"the mark {event!r} was not acknowledged by every reader within {ACK_TIMEOUT_S:g} s")
    print(f"episode marked {event}")
    return 0
