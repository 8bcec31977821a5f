"""Time series of one recorded run, read from its bag, for the experiments (stability, E2 success, E3 energy).

Reads the rosbag2-layout MCAP that the recorder writes (finished or torn: recording.bag_reader.read_messages) and
decodes only the topics asked for, with the ros2msg schemas embedded in the bag (mcap_ros2), so it needs neither rclpy
nor the message packages. Times are the messages' header stamps in seconds (simulation time in lockstep).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from mcap_ros2.decoder import DecoderFactory

from fic_teleop_tools.recording.bag_reader import ReadResult, read_messages

FIC_STATE = "/replica/fic_state"
LIMIT_STATUS = "/replica/limit_status"
WRENCH = "/ft_sensor/wrench"
OBJECT_POSES = "/sim/object_poses"
DIAGNOSTICS = "/diagnostics"
JOINT_STATES = "/joint_states"


def _stamp(message) -> float:
    return message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec


@dataclass
class RunSeries:
    """What the experiments read from one bag (arrays empty when a topic is missing)."""

    fic_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    error: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))          # x_d - x_R translation [m]
    total_energy: np.ndarray = field(default_factory=lambda: np.zeros(0))        # [J]
    master_stale: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    controller: str = ""
    limit_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    violation_ticks: np.ndarray = field(default_factory=lambda: np.zeros(0))     # cumulative
    shaped_ticks: np.ndarray = field(default_factory=lambda: np.zeros(0))        # cumulative
    wrench_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    force: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))          # F/T force at the TCP [N]
    pose_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    object_positions: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3)))  # (n, objects, 3) [m]
    joint_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    joint_velocity: np.ndarray = field(default_factory=lambda: np.zeros((0, 7)))
    diagnostics: dict[str, dict[str, str]] = field(default_factory=dict)         # last values per status name
    counts: dict[str, int] = field(default_factory=dict)                          # messages per topic in the bag
    complete: bool = False                                                        # the bag had its footer


def read_run(bag: str | Path, *, joint_states: bool = False, stride: dict[str, int] | None = None) -> RunSeries:
    """Decode the experiment topics of ``bag``. ``stride``: keep every k-th message of a topic (e.g. the 1 kHz
    wrench for a force peak needs all, an object pose for a final position needs few)."""
    wanted = {FIC_STATE, LIMIT_STATUS, WRENCH, OBJECT_POSES, DIAGNOSTICS} | ({JOINT_STATES} if joint_states else set())
    stride = stride or {}
    factory = DecoderFactory()
    decoders: dict[int, object] = {}
    seen: dict[str, int] = {}
    fic, limits, wrenches, poses, joints = [], [], [], [], []
    diagnostics: dict[str, dict[str, str]] = {}
    controller = ""
    result = ReadResult()
    for schema, channel, message in read_messages(bag, result):
        topic = channel.topic
        index = seen.get(topic, 0)
        seen[topic] = index + 1
        if topic not in wanted or index % stride.get(topic, 1):
            continue
        decoder = decoders.get(channel.id)
        if decoder is None:
            decoder = decoders[channel.id] = factory.decoder_for(channel.message_encoding, schema)
        msg = decoder(message.data)
        if topic == FIC_STATE:
            fic.append((_stamp(msg), *msg.error[:3], msg.total_energy, msg.master_stale))
            controller = msg.controller
        elif topic == LIMIT_STATUS:
            limits.append((_stamp(msg), msg.violation_ticks, msg.shaped_ticks))
        elif topic == WRENCH:
            f = msg.wrench.force
            wrenches.append((_stamp(msg), f.x, f.y, f.z))
        elif topic == OBJECT_POSES:
            poses.append((_stamp(msg), [(p.position.x, p.position.y, p.position.z) for p in msg.poses]))
        elif topic == JOINT_STATES:
            joints.append((_stamp(msg), list(msg.velocity)))
        elif topic == DIAGNOSTICS:
            for status in msg.status:
                diagnostics[status.name] = {kv.key: kv.value for kv in status.values}
    run = RunSeries(controller=controller, diagnostics=diagnostics, counts=seen, complete=result.complete)
    if fic:
        a = _sorted(np.array(fic, dtype=np.float64))
        run.fic_time, run.error, run.total_energy, run.master_stale = a[:, 0], a[:, 1:4], a[:, 4], a[:, 5] > 0.5
    if limits:
        a = _sorted(np.array(limits, dtype=np.float64))
        run.limit_time, run.violation_ticks, run.shaped_ticks = a[:, 0], a[:, 1], a[:, 2]
    if wrenches:
        a = _sorted(np.array(wrenches, dtype=np.float64))
        run.wrench_time, run.force = a[:, 0], a[:, 1:4]
    if poses:
        poses.sort(key=lambda item: item[0])
        run.pose_time = np.array([p[0] for p in poses])
        run.object_positions = np.array([p[1] for p in poses], dtype=np.float64).reshape(len(poses), -1, 3)
    if joints:
        joints.sort(key=lambda item: item[0])
        run.joint_time = np.array([j[0] for j in joints])
        run.joint_velocity = np.array([j[1] for j in joints], dtype=np.float64)
    return run


def _sorted(array: np.ndarray) -> np.ndarray:
    """Rows sorted by time, duplicate stamps dropped (the first kept), so time is strictly increasing."""
    array = array[np.argsort(array[:, 0], kind="stable")]
    keep = np.concatenate([[True], np.diff(array[:, 0]) > 0.0])
    return array[keep]
