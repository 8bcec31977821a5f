"""Read a recorded session into numpy arrays, with the mcap library and mcap-ros2-support only.

Deliberately independent of fic_teleop_tools.recording.bag_writer: the report must read any rosbag2-layout MCAP bag (one
written by `ros2 bag record -s mcap` as well as ours), so it relies on nothing but the files' own schemas.
Messages are read sequentially (mcap's StreamReader, CRCs checked), so a bag whose recorder was killed (no
summary, no footer) reads up to its last complete chunk; `BagData.complete` says whether the footer was there.

Time bases: `stamp` arrays are header stamps (the publishers' clocks: sim time in lockstep mode) in seconds;
`log` arrays are the recorder's receive times (wall clock) in seconds. Header stamps of the high-rate topics are
read straight from the CDR bytes, without decoding the whole message.
"""
from __future__ import annotations

import json
import struct
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml
from mcap.records import Channel
from mcap_ros2.decoder import DecoderFactory

from fic_teleop_tools.recording.bag_reader import BagReadError, ReadResult, mcap_file, read_messages

# Topics decoded in full (everything else is only counted).
POSE_TOPICS = ("/replica/desired_pose", "/replica/tcp_pose", "/planner/desired_pose", "/master/pose")
WRENCH_TOPICS = ("/ft_sensor/wrench", "/replica/feedback_wrench", "/master/feedback_wrench")
TELEOP_TOPICS = ("/master/teleop_command", "/replica/teleop_command")
FIC_STATE_TOPIC = "/replica/fic_state"
LIMIT_STATUS_TOPIC = "/replica/limit_status"
DELIVERY_TOPIC = "/channel/deliveries"
DIAGNOSTICS_TOPIC = "/diagnostics"
# Only the stamps (parsed from the CDR bytes).
STAMP_ONLY_TOPICS = ("/joint_states",)
CLOCK_TOPIC = "/clock"
# Forward direction of the channel (master -> replica): the one whose delay the latency metric subtracts.
FORWARD_TOPICS = ("/replica/teleop_command", "/replica/master_pose")
#: A driver's topic that stands in for one of ours (docs/HARDWARE.md): franka_ros2's 1 kHz joint states and its
#: external-wrench estimate are read as /joint_states and /ft_sensor/wrench. When a bag holds both (franka_ros2's
#: /joint_states is joint_state_publisher's 30 Hz merge), the driver's stream is used and ours is left out.
HARDWARE_TOPIC_ALIASES = {
    "/franka/joint_states": "/joint_states",
    "/franka_robot_state_broadcaster/external_wrench_in_base_frame": "/ft_sensor/wrench",
}
_SHADOWED = "#shadowed"


def _stamp(time_msg) -> float:
    return time_msg.sec + time_msg.nanosec * 1e-9


def _stamp_ns(time_msg) -> int:
    return time_msg.sec * 1_000_000_000 + time_msg.nanosec


def _cdr_joint_velocities(cdr: bytes) -> tuple[float, ...]:
    """sensor_msgs/JointState.velocity straight from its CDR bytes (header, name[], position[], velocity[]): a
    decoded JointState costs the report about 30 us, and a run's bag holds 500 of them a second.
    Alignment is counted from the CDR body (after the 4-byte encapsulation header)."""
    order = "<" if cdr[1] & 1 else ">"
    body = memoryview(cdr)[4:]
    offset = 8                                                  # header.stamp
    (length,) = struct.unpack_from(order + "I", body, offset)   # header.frame_id (with its NUL)
    offset += 4 + length
    offset += -offset % 4
    (names,) = struct.unpack_from(order + "I", body, offset)
    offset += 4
    for _ in range(names):
        offset += -offset % 4
        (length,) = struct.unpack_from(order + "I", body, offset)
        offset += 4 + length
    for sequence in ("position", "velocity"):
        offset += -offset % 4
        (count,) = struct.unpack_from(order + "I", body, offset)
        offset += 4
        if count:
            offset += -offset % 8
        if sequence == "velocity":
            return struct.unpack_from(f"{order}{count}d", body, offset)
        offset += 8 * count
    return ()


def _cdr_time_ns(cdr: bytes) -> int:
    """The first builtin_interfaces/Time of a CDR message (Header.stamp, or Clock.clock)."""
    sec, nanosec = struct.unpack_from("<iI" if cdr[1] & 1 else ">iI", cdr, 4)
    return sec * 1_000_000_000 + nanosec


@dataclass
class Series:
    """Time series of one topic: stamps [s], receive times [s] and named value columns."""
    stamp: np.ndarray
    log: np.ndarray
    values: dict[str, np.ndarray] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.stamp)


@dataclass
class BagData:
    path: Path
    complete: bool
    stopped_by: str
    counts: dict[str, int]
    types: dict[str, str]
    series: dict[str, Series]
    controller: str
    deliveries: dict[str, dict[int, float]]  # topic -> {delivered message's stamp [ns]: held [s]}
    first_log: float
    last_log: float
    # (stamp [s], joint names, positions) of /joint_states at least `keyframe_interval` apart (load_bag option)
    key_joint_states: list[tuple[float, list[str], list[float]]] = field(default_factory=list)
    # topic -> messages DDS lost before the recorder took them (metadata.yaml custom_data `lost_messages`, written
    # by our recorder); None: the bag does not say (another recorder, or a recorder killed before its footer)
    lost_messages: dict[str, int] | None = None
    # /diagnostics: each status name's key-values as its last message (by log time) gave them
    diagnostics: dict[str, dict[str, str]] = field(default_factory=dict)
    # /joint_states' velocities, one row per message of series["/joint_states"] (load_bag's joint_velocities)
    joint_velocity: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    def has(self, topic: str) -> bool:
        return topic in self.series and len(self.series[topic]) > 0


def load_bag(bag: str | Path, keyframe_interval: float | None = None, joint_velocities: bool = False) -> BagData:
    """Read a bag; with `keyframe_interval`, also decode /joint_states every that many seconds (key frames); with
    `joint_velocities`, every joint state's velocities (the run verdict's joint speeds)."""
    path = mcap_file(bag)
    status = ReadResult()
    schemas, channels = status.schemas, status.channels
    decoders: dict[int, object] = {}
    factory = DecoderFactory()
    counts: Counter = Counter()
    rows: dict[str, list] = defaultdict(list)
    deliveries: dict[str, dict[int, float]] = defaultdict(dict)
    controllers: Counter = Counter()
    key_lists: dict[str, list] = defaultdict(list)  # row key -> key frames (a driver's stream or ours, aliases)
    velocity_lists: dict[str, list] = defaultdict(list)  # row key -> joint velocities, one per row
    diagnostics: dict[str, dict[str, str]] = {}
    first_log, last_log = np.inf, -np.inf
    decoded = set(POSE_TOPICS + WRENCH_TOPICS + TELEOP_TOPICS + (FIC_STATE_TOPIC, LIMIT_STATUS_TOPIC, DELIVERY_TOPIC,
                                                                      DIAGNOSTICS_TOPIC))
    try:
        for _, channel, record in read_messages(path, status):
            topic = channel.topic
            counts[topic] += 1
            store = topic  # the row key: a driver's stream under our name, ours aside until we know (see aliases)
            if topic in HARDWARE_TOPIC_ALIASES:
                topic = store = HARDWARE_TOPIC_ALIASES[topic]
            elif topic in HARDWARE_TOPIC_ALIASES.values():
                store = topic + _SHADOWED
            log = record.log_time * 1e-9
            first_log, last_log = min(first_log, log), max(last_log, log)
            if topic in STAMP_ONLY_TOPICS or topic == CLOCK_TOPIC:
                stamp = _cdr_time_ns(record.data) * 1e-9
                rows[store].append((stamp, log))
                if joint_velocities and topic == "/joint_states":
                    velocity_lists[store].append(_cdr_joint_velocities(record.data))
                key_joint_states = key_lists[store]
                if keyframe_interval and topic == "/joint_states" and (
                        not key_joint_states or stamp >= key_joint_states[-1][0] + keyframe_interval):
                    joint_state = _decoder(factory, decoders, record.channel_id, channel, schemas)(record.data)
                    key_joint_states.append((stamp, list(joint_state.name), list(joint_state.position)))
                continue
            if topic not in decoded:
                continue
            msg = _decoder(factory, decoders, record.channel_id, channel, schemas)(record.data)
            if topic in POSE_TOPICS:
                p = msg.pose.position
                rows[store].append((_stamp(msg.header.stamp), log, p.x, p.y, p.z))
            elif topic in WRENCH_TOPICS:
                f = msg.wrench.force
                rows[store].append((_stamp(msg.header.stamp), log, f.x, f.y, f.z))
            elif topic in TELEOP_TOPICS:
                h, d = msg.handle_position, msg.desired_offset
                rows[topic].append((_stamp(msg.header.stamp), log, h.x, h.y, h.z, d.x, d.y, d.z, msg.haptic_gain))
            elif topic == FIC_STATE_TOPIC:
                controllers[msg.controller] += 1
                error = list(msg.error)[:3] + [np.nan] * (3 - min(3, len(msg.error)))
                phase = list(msg.phase)[:3] + [-1] * (3 - min(3, len(msg.phase)))
                rows[topic].append((_stamp(msg.header.stamp), log, *error, *phase, msg.total_energy,
                                    _stamp_ns(msg.master_stamp), msg.master_age, float(msg.master_stale),
                                    float(getattr(msg, "passivity_margin_min", np.nan)),
                                    float(getattr(msg, "passivity_violation_ticks", 0)),
                                    float(sum(getattr(msg, "port_work", []))), float(sum(msg.stored_energy))))
            elif topic == LIMIT_STATUS_TOPIC:
                rows[topic].append((_stamp(msg.header.stamp), log, float(msg.shaping), float(msg.violations),
                                    float(getattr(msg, "violation_ticks", 0)), float(getattr(msg, "shaped_ticks", 0)),
                                    float(getattr(msg, "ticks", 0))))
            elif topic == DELIVERY_TOPIC:
                deliveries[msg.topic].setdefault(_stamp_ns(msg.header.stamp), float(msg.held))
            elif topic == DIAGNOSTICS_TOPIC:
                for part in msg.status:
                    diagnostics[part.name] = {value.key: value.value for value in part.values}
    except OSError as error:
        raise BagReadError(f"{path}: {error}") from error
    if not status.complete and not counts and not schemas:
        raise BagReadError(f"{path}: not an MCAP file or empty ({status.stopped_by})")

    for ours in HARDWARE_TOPIC_ALIASES.values():  # our own stream only where no driver stream stood in for it
        shadowed = rows.pop(ours + _SHADOWED, None)
        if shadowed and not rows.get(ours):
            rows[ours] = shadowed
            key_lists[ours] = key_lists.pop(ours + _SHADOWED, [])
            velocity_lists[ours] = velocity_lists.pop(ours + _SHADOWED, [])
    key_joint_states = key_lists.get("/joint_states", [])
    velocities = velocity_lists.get("/joint_states", [])
    joint_velocity = np.array(velocities, dtype=float) if velocities and len({len(v) for v in velocities}) == 1 \
        else np.zeros((0, 0))
    columns = {
        "pose": ("x", "y", "z"),
        "wrench": ("fx", "fy", "fz"),
        "teleop": ("handle_x", "handle_y", "handle_z", "offset_x", "offset_y", "offset_z", "haptic_gain"),
        "fic": ("ex", "ey", "ez", "phase_x", "phase_y", "phase_z", "total_energy", "master_stamp_ns",
                "master_age", "master_stale", "passivity_margin_min", "passivity_violation_ticks", "port_work",
                "storage"),
        "limit": ("shaping", "violations", "violation_ticks", "shaped_ticks", "ticks"),
        "stamps": (),
    }
    kinds = {**{t: "pose" for t in POSE_TOPICS}, **{t: "wrench" for t in WRENCH_TOPICS},
             **{t: "teleop" for t in TELEOP_TOPICS}, FIC_STATE_TOPIC: "fic", LIMIT_STATUS_TOPIC: "limit",
             CLOCK_TOPIC: "stamps", **{t: "stamps" for t in STAMP_ONLY_TOPICS}}
    series: dict[str, Series] = {}
    for topic, kind in kinds.items():
        if not rows.get(topic):
            continue
        if kind == "fic":  # master stamps as exact integers (they are matched with delivery stamps)
            table = rows[topic]
            master_ns = np.array([r[9] for r in table], dtype=np.int64)
            array = np.array([r[:9] + (0.0,) + r[10:] for r in table], dtype=float)
        else:
            array = np.array(rows[topic], dtype=float)
        values = {name: array[:, 2 + i] for i, name in enumerate(columns[kind])}
        if kind == "fic":
            values["master_stamp_ns"] = master_ns
        series[topic] = Series(array[:, 0], array[:, 1], values)

    types = {}
    for channel in channels.values():
        schema = schemas.get(channel.schema_id)
        types[channel.topic] = schema.name if schema else ""
    return BagData(path=path, complete=status.complete, stopped_by=status.stopped_by, counts=dict(counts),
                   types=types, series=series, controller=controllers.most_common(1)[0][0] if controllers else "",
                   deliveries=dict(deliveries), first_log=float(first_log) if counts else 0.0,
                   last_log=float(last_log) if counts else 0.0, key_joint_states=key_joint_states,
                   lost_messages=recorder_lost_messages(path.parent / "metadata.yaml"), diagnostics=diagnostics,
                   joint_velocity=joint_velocity)


def recorder_lost_messages(metadata_path: Path) -> dict[str, int] | None:
    """The recorder's DDS message-lost counts per topic from a bag's metadata.yaml, or None when it has none."""
    try:
        metadata = yaml.safe_load(metadata_path.read_text())
        lost = metadata["rosbag2_bagfile_information"]["custom_data"]["lost_messages"]
        return {str(topic): int(count) for topic, count in json.loads(lost).items()}
    except (OSError, KeyError, TypeError, ValueError, yaml.YAMLError):
        return None


def _decoder(factory: DecoderFactory, decoders: dict, channel_id: int, channel: Channel, schemas: dict):
    decoder = decoders.get(channel_id)
    if decoder is None:
        decoder = factory.decoder_for(channel.message_encoding, schemas.get(channel.schema_id))
        if decoder is None:
            raise BagReadError(f"cannot decode {channel.topic} ({channel.message_encoding})")
        decoders[channel_id] = decoder
    return decoder
