"""One recorded run as the dataset export needs it: the streams of its features, its markers, its scene and task.

A run folder is what the launcher writes (``runs/<date-time>/``: ``run.json`` and the bag in ``bag/``); a bare bag
folder is taken too, with the scene and the task from the command line. Every value is read with its header
stamp (the publisher's clock at sampling time), in integer nanoseconds, with the bag's own schemas (mcap-ros2).
Bad input is a RecordingError with one line that names the run and what is wrong: a torn bag, a stream the
dataset needs that the bag lacks (a run without a camera), a run folder without a bag.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from mcap_ros2.decoder import DecoderFactory
from numpy.typing import NDArray

from fic_teleop_runtime.episode_markers import MARKER_TOPIC, EpisodeOutcome, MarkerError, outcome
from fic_teleop_tools.recording.bag_reader import BagReadError, ReadResult, mcap_file, read_messages

JOINT_STATES = "/joint_states"
TCP_POSE = "/replica/tcp_pose"
WRIST_WRENCH = "/ft_sensor/wrench"
HANDLE_POSE = "/haptic/pose"
HANDLE_WRENCH = "/haptic/wrench_command"
SET_POINT = "/replica/desired_pose"
#: The simulation's movable bodies (robot_node, /sim/object_poses): with the joint states, what the scene's camera
#: is rendered from after the run.
OBJECT_POSES = "/sim/object_poses"
POSE_TOPICS = (TCP_POSE, HANDLE_POSE, SET_POINT)
WRENCH_TOPICS = (WRIST_WRENCH, HANDLE_WRENCH)
#: Every stream a dataset frame is made of.
STREAMS = (JOINT_STATES, *POSE_TOPICS, *WRENCH_TOPICS, OBJECT_POSES)


class RecordingError(ValueError):
    """A run that cannot be exported; the message is one line that says which and why."""


@dataclass
class Stream:
    stamps: NDArray[np.int64]   # header stamps [ns]
    values: NDArray[np.float64]  # one row a sample


@dataclass
class RunRecording:
    name: str
    bag: Path
    scene: str
    task: str
    joint_names: list[str]
    streams: dict[str, Stream]
    outcome: EpisodeOutcome
    extra: dict[str, str] = field(default_factory=dict)


def _pose_row(pose) -> list[float]:
    p, q = pose.position, pose.orientation
    return [p.x, p.y, p.z, q.x, q.y, q.z, q.w]


def _wrench_row(wrench) -> list[float]:
    f, t = wrench.force, wrench.torque
    return [f.x, f.y, f.z, t.x, t.y, t.z]


def _stamp_ns(header) -> int:
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def bag_folder(run: Path) -> Path:
    """The bag of a run folder (its bag/), or the path itself when it is a bag."""
    return run / "bag" if (run / "bag").is_dir() else run


def read_run(run: str | Path, task: str | None = None, scene: str | None = None) -> RunRecording:
    """Read a run folder (or a bag folder) for export; RecordingError says why it cannot be."""
    run = Path(run)
    if not run.exists():
        raise RecordingError(f"{run}: no such run folder")
    settings = {}
    if (run / "run.json").is_file():
        try:
            settings = json.loads((run / "run.json").read_text())
        except (OSError, ValueError) as error:
            raise RecordingError(f"{run}: run.json cannot be read ({error})") from None
    scene = scene or settings.get("scene")
    if not scene:
        raise RecordingError(f"{run}: no camera: the run names no simulated scene to render (run.json has no "
                             "scene; a bag alone needs --scene)")
    bag = bag_folder(run)
    try:
        path = mcap_file(bag)
    except BagReadError as error:
        raise RecordingError(f"{run}: no bag ({error})") from None
    result = ReadResult()
    rows: dict[str, list] = {topic: [] for topic in STREAMS}
    stamps: dict[str, list[int]] = {topic: [] for topic in STREAMS}
    marks: list[str] = []
    joint_names: list[str] | None = None
    decoders: dict[int, object] = {}
    factory = DecoderFactory()
    for schema, channel, message in read_messages(path, result):
        topic = channel.topic
        if topic not in rows and topic != MARKER_TOPIC:
            continue
        decoder = decoders.get(channel.id)
        if decoder is None:
            decoder = decoders[channel.id] = factory.decoder_for(channel.message_encoding, schema)
        msg = decoder(message.data)
        if topic == MARKER_TOPIC:
            marks.append(msg.data)
            continue
        stamps[topic].append(_stamp_ns(msg.header))
        if topic == JOINT_STATES:
            names = list(msg.name)
            if joint_names is None:
                joint_names = names
            elif names != joint_names:
                raise RecordingError(f"{run}: {JOINT_STATES} changes its joint names within the run")
            if len(msg.velocity) != len(names) or len(msg.position) != len(names):
                raise RecordingError(f"{run}: {JOINT_STATES} does not give a position and a velocity for every "
                                     "joint, which observation.state needs")
            rows[topic].append(list(msg.position) + list(msg.velocity))
        elif topic in POSE_TOPICS:
            rows[topic].append(_pose_row(msg.pose))
        elif topic in WRENCH_TOPICS:
            rows[topic].append(_wrench_row(msg.wrench))
        else:  # the object poses, flattened: (x y z qx qy qz qw) per body
            rows[topic].append([value for pose in msg.poses for value in _pose_row(pose)])
    if not result.complete:
        raise RecordingError(f"{run}: the bag is torn ({result.stopped_by}; its recorder was stopped before it "
                             f"finished): `scripts/fic bag recover {bag} NEW_BAG` rewrites it, then export that")
    missing = [topic for topic in STREAMS if not stamps[topic]]
    if OBJECT_POSES in missing:
        raise RecordingError(f"{run}: no camera: the bag has no {OBJECT_POSES} (the scene's state the camera is "
                             "rendered from; the robot's object_pose_rate_hz was 0, or it is not a simulated run)")
    if missing:
        raise RecordingError(f"{run}: the bag has no {', '.join(missing)}, which the dataset's features need")
    try:
        episode = outcome(marks)
    except MarkerError as error:
        raise RecordingError(f"{run}: {error}") from None
    streams = {}
    for topic in STREAMS:
        widths = {len(row) for row in rows[topic]}
        if len(widths) != 1:
            raise RecordingError(f"{run}: {topic} changes its size within the run ({sorted(widths)})")
        order = np.argsort(np.asarray(stamps[topic], dtype=np.int64), kind="stable")
        streams[topic] = Stream(np.asarray(stamps[topic], dtype=np.int64)[order],
                                np.asarray(rows[topic], dtype=np.float64)[order])
    return RunRecording(name=run.resolve().name, bag=path, scene=str(scene),
                        task=task or settings.get("task") or default_task(str(scene)),
                        joint_names=joint_names or [], streams=streams, outcome=episode)


#: A task string for each scene, when neither the run nor the command line gives one.
DEFAULT_TASKS = {
    "superimposition": "follow the circle, steer the arm over the fixed obstacle and push the free box away",
    "shape_sorting": "pick each shape, insert it through its hole and pull it free",
    "free_space": "move the arm in free space",
}


def default_task(scene: str) -> str:
    return DEFAULT_TASKS.get(scene, f"teleoperate the arm in the {scene} scene")
