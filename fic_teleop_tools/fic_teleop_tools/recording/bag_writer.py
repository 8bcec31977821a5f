"""A rosbag2-layout MCAP bag writer that survives being killed.

Layout, as `ros2 bag record -s mcap` writes it:

    <bag_dir>/<name>_0.mcap      profile "ros2"; one schema per type, encoding "ros2msg"
                                 (the .msg text with its dependencies appended, each after a line of 80 '='
                                 and "MSG: pkg/Type", the way rosbag2's LocalMessageDefinitionSource does);
                                 one channel per topic, message encoding "cdr", channel metadata
                                 "offered_qos_profiles" (YAML) and "topic_type_hash"
    <bag_dir>/metadata.yaml      rosbag2_bagfile_information, version 9 (Jazzy), written by finish()

Messages are raw CDR bytes (what an rclpy subscription with raw=True hands over); nothing is deserialised.

Crash safety: messages go into small compressed chunks (default 256 KiB, zstd) and `flush()` (called every
flush period by the owner) closes the chunk in progress and hands it to the kernel unbuffered. After a SIGKILL
the file lacks only its summary and footer, and every complete chunk is still readable sequentially:
`bag_reader.read_messages()` (the mcap library's non-seeking StreamReader with CRC validation, stopping cleanly
at the torn tail) reads it, and `recovery.recover()` rewrites it into a complete bag that every tool opens.

Pure Python (mcap, PyYAML); no rclpy import.
"""
from __future__ import annotations

import json
import os
import re
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from mcap.writer import CompressionType, Writer

ROSBAG2_VERSION = 9  # rosbag2 metadata version of ROS 2 Jazzy
DELIMITER = "=" * 80
_PRIMITIVE_TYPES = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
                    "uint32", "int64", "uint64", "string", "wstring"}
# The first word of each .msg line is a field type ("pkg/Type", "Type", "float64[3]"): rosbag2's own regex.
_FIELD_TYPE = re.compile(r"(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+")
_TYPE_NAME = re.compile(r"^([a-zA-Z0-9_]+)/(?:msg/)?([a-zA-Z0-9_]+)$")


class BagError(RuntimeError):
    """The bag cannot be written as asked (existing bag, unknown type, writing after finish)."""


class MessageDefinitionError(LookupError):
    """No .msg file for a type was found under the ament prefixes."""


# ---------------------------------------------------------------------------------------------------------
# Message definitions (.msg text from the ament prefixes)
# ---------------------------------------------------------------------------------------------------------
def _split_type(type_name: str) -> tuple[str, str]:
    match = _TYPE_NAME.match(type_name)
    if not match:
        raise MessageDefinitionError(f"type name {type_name!r} is not of the form pkg/msg/Type or pkg/Type")
    return match.group(1), match.group(2)


def _ament_prefixes() -> list[Path]:
    return [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]


def find_interface_file(type_name: str, suffix: str = ".msg") -> Path:
    """`<prefix>/share/<pkg>/msg/<Type><suffix>` for the first AMENT_PREFIX_PATH prefix that has it."""
    package, name = _split_type(type_name)
    for prefix in _ament_prefixes():
        path = prefix / "share" / package / "msg" / f"{name}{suffix}"
        if path.is_file():
            return path
    raise MessageDefinitionError(
        f"no msg/{name}{suffix} of package {package!r} under AMENT_PREFIX_PATH "
        f"({os.environ.get('AMENT_PREFIX_PATH', '<unset>')}); source scripts/env.sh")


def message_definition(type_name: str) -> str:
    """The complete ros2msg definition of a type, as rosbag2 stores it in an MCAP schema.

    The type's own .msg text first, then each dependency (depth first, each once, sorted within a level)
    after a line of 80 '=' and "MSG: pkg/Type" (the name as the .msg text spells it).
    """
    seen: set[str] = set()

    def text_with_dependencies(dep_type: str) -> str:
        package, _ = _split_type(dep_type)
        text = find_interface_file(dep_type).read_text()
        dependencies = set()
        for field_type in _FIELD_TYPE.findall(text):
            if field_type in _PRIMITIVE_TYPES:
                continue
            dependencies.add(field_type if "/" in field_type else f"{package}/{field_type}")
        result = text
        for dependency in sorted(dependencies):
            if dependency in seen:
                continue
            seen.add(dependency)
            result += f"\n{DELIMITER}\nMSG: {dependency}\n" + text_with_dependencies(dependency)
        return result

    return text_with_dependencies(type_name)


def type_description_hash(type_name: str) -> str:
    """The REP-2016 type hash (RIHS01_...) from the type's generated .json, or '' if there is none."""
    package, name = _split_type(type_name)
    try:
        description = json.loads(find_interface_file(type_name, ".json").read_text())
    except (MessageDefinitionError, OSError, ValueError):
        return ""
    full_name = f"{package}/msg/{name}"
    for entry in description.get("type_hashes", []):
        if entry.get("type_name") == full_name:
            return str(entry.get("hash_string", ""))
    return ""


def full_type_name(type_name: str) -> str:
    """'pkg/Type' or 'pkg/msg/Type' -> 'pkg/msg/Type' (the form rosbag2 uses for topic types and schemas)."""
    package, name = _split_type(type_name)
    return f"{package}/msg/{name}"


# ---------------------------------------------------------------------------------------------------------
# QoS profiles as rosbag2 stores them (metadata version 9)
# ---------------------------------------------------------------------------------------------------------
_INFINITE = {"sec": 2147483647, "nsec": 4294967295}


def qos_profile_dict(*, reliability: str = "reliable", durability: str = "volatile", history: str = "keep_last",
                     depth: int = 1000) -> dict:
    """One offered QoS profile in rosbag2's version-9 YAML form."""
    return {"history": history, "depth": int(depth), "reliability": reliability, "durability": durability,
            "deadline": dict(_INFINITE), "lifespan": dict(_INFINITE), "liveliness": "automatic",
            "liveliness_lease_duration": dict(_INFINITE), "avoid_ros_namespace_conventions": False}


# ---------------------------------------------------------------------------------------------------------
# The writer
# ---------------------------------------------------------------------------------------------------------
class _UnbufferedFile:
    """A write-through file: every record the mcap Writer emits reaches the kernel at once, so a SIGKILL loses
    nothing that the Writer already produced (a BufferedWriter would keep up to 8 KiB in the process)."""

    def __init__(self, path: Path) -> None:
        self._fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        self._position = 0

    def write(self, data: bytes) -> int:
        view = memoryview(data)
        while view:
            written = os.write(self._fd, view)
            view = view[written:]
        self._position += len(data)
        return len(data)

    def tell(self) -> int:
        return self._position

    def flush(self) -> None:
        pass

    def fsync(self) -> None:
        os.fsync(self._fd)

    def close(self) -> None:
        os.close(self._fd)


@dataclass
class TopicInfo:
    name: str
    type: str  # pkg/msg/Type
    channel_id: int
    offered_qos_profiles: list[dict]
    type_hash: str
    message_count: int = 0


@dataclass
class BagSummary:
    """What finish() wrote."""
    bag_dir: Path
    mcap_path: Path
    message_count: int
    start_ns: int
    end_ns: int
    topics: dict[str, int] = field(default_factory=dict)  # topic -> message count


class BagWriter:
    """Write raw CDR messages to `<bag_dir>/<name>_0.mcap` + `metadata.yaml` (rosbag2 layout, storage mcap).

    Not thread-safe: call it from one thread (the recorder's writer thread).

        bag = BagWriter("bags/run1")
        bag.add_topic("/joint_states", "sensor_msgs/msg/JointState")
        bag.write("/joint_states", cdr_bytes, log_time_ns)
        bag.flush()        # periodically: closes the chunk in progress (crash safety)
        bag.finish()       # summary, footer, metadata.yaml
    """

    def __init__(self, bag_dir: str | os.PathLike, *, chunk_size: int = 256 * 1024, compression: str = "zstd",
                 flush_period: float = 0.5) -> None:
        self.bag_dir = Path(bag_dir)
        if self.bag_dir.exists() and any(self.bag_dir.iterdir()):
            raise BagError(f"bag folder {self.bag_dir} exists and is not empty; choose a new bag_path")
        if chunk_size < 1024:
            raise BagError(f"chunk_size {chunk_size} is too small (>= 1024 bytes)")
        try:
            compression_type = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                                "none": CompressionType.NONE}[compression]
        except KeyError:
            raise BagError(f"compression {compression!r} is not one of zstd, lz4, none") from None
        self.bag_dir.mkdir(parents=True, exist_ok=True)
        self.mcap_path = self.bag_dir / f"{self.bag_dir.name}_0.mcap"
        self.flush_period = float(flush_period)
        self._file = _UnbufferedFile(self.mcap_path)
        self._writer = Writer(self._file, chunk_size=chunk_size, compression=compression_type)
        self._writer.start(profile="ros2", library="fic_teleop fic_teleop_tools.recording.bag_writer")
        self._schemas: dict[str, int] = {}
        self.topics: dict[str, TopicInfo] = {}
        self._by_channel: dict[int, TopicInfo] = {}
        self._start_ns: int | None = None
        self._end_ns = 0
        self._last_flush = time.monotonic()
        self._finished = False
        self._lock = threading.Lock()  # finish() may be called from a signal/shutdown path
        self.summary: BagSummary | None = None

    # -- topics and messages ---------------------------------------------------------------------------------
    def add_topic(self, topic: str, type_name: str, *, offered_qos_profiles: list[dict] | None = None,
                  definition: str | None = None, type_hash: str | None = None) -> int:
        """Register a topic (once); returns its MCAP channel id. Reads the .msg files unless `definition` is given."""
        self._check_open()
        if topic in self.topics:
            existing = self.topics[topic]
            if existing.type != full_type_name(type_name):
                raise BagError(f"topic {topic} is already recorded as {existing.type}, not {type_name}")
            return existing.channel_id
        msg_type = full_type_name(type_name)
        if msg_type not in self._schemas:
            text = definition if definition is not None else message_definition(msg_type)
            self._schemas[msg_type] = self._writer.register_schema(name=msg_type, encoding="ros2msg",
                                                                   data=text.encode())
        profiles = offered_qos_profiles if offered_qos_profiles is not None else [qos_profile_dict()]
        digest = type_hash if type_hash is not None else type_description_hash(msg_type)
        metadata = {"offered_qos_profiles": yaml.safe_dump(profiles, sort_keys=False).strip()}
        if digest:
            metadata["topic_type_hash"] = digest
        channel_id = self._writer.register_channel(topic=topic, message_encoding="cdr",
                                                   schema_id=self._schemas[msg_type], metadata=metadata)
        info = TopicInfo(topic, msg_type, channel_id, profiles, digest)
        self.topics[topic] = info
        self._by_channel[channel_id] = info
        return channel_id

    def write(self, topic: str | int, data: bytes, log_time_ns: int, publish_time_ns: int | None = None) -> None:
        """Append one CDR-serialised message (topic name or channel id from add_topic)."""
        self._check_open()
        info = self._by_channel[topic] if isinstance(topic, int) else self.topics.get(topic)
        if info is None:
            raise BagError(f"topic {topic!r} was not added (add_topic first)")
        info.message_count += 1
        self._writer.add_message(channel_id=info.channel_id, log_time=log_time_ns, data=data,
                                 publish_time=log_time_ns if publish_time_ns is None else publish_time_ns,
                                 sequence=info.message_count)
        if self._start_ns is None or log_time_ns < self._start_ns:
            self._start_ns = log_time_ns
        self._end_ns = max(self._end_ns, log_time_ns)

    def maybe_flush(self) -> bool:
        """flush() if the flush period has passed since the last one; True if it flushed."""
        if time.monotonic() - self._last_flush >= self.flush_period:
            self.flush()
            return True
        return False

    def flush(self) -> None:
        """Close the chunk in progress and write it out: everything written so far survives a SIGKILL."""
        self._check_open()
        self._writer.flush()
        self._last_flush = time.monotonic()

    @property
    def message_count(self) -> int:
        return sum(t.message_count for t in self.topics.values())

    @property
    def finished(self) -> bool:
        return self._finished

    # -- closing ---------------------------------------------------------------------------------------------
    def finish(self, custom_data: dict[str, str] | None = None) -> BagSummary:
        """Write the last chunk, rosbag2's metadata record, the summary and footer, and metadata.yaml, with
        ``custom_data`` (strings, rosbag2's own key-value map) added to the writer's.

        Idempotent: a second call returns the first call's summary.
        """
        with self._lock:
            if self._finished:
                assert self.summary is not None
                return self.summary
            self._finished = True
            metadata = self._rosbag2_metadata()
            metadata["rosbag2_bagfile_information"]["custom_data"].update(
                {str(key): str(value) for key, value in (custom_data or {}).items()})
            self._writer.add_metadata("rosbag2", {"serialized_metadata": yaml.safe_dump(
                metadata["rosbag2_bagfile_information"], sort_keys=False)})
            self._writer.finish()
            self._file.fsync()
            self._file.close()
            temporary = self.bag_dir / "metadata.yaml.tmp"
            temporary.write_text(yaml.safe_dump(metadata, sort_keys=False))
            temporary.replace(self.bag_dir / "metadata.yaml")
            self.summary = BagSummary(self.bag_dir, self.mcap_path, self.message_count, self._start_ns or 0,
                                      self._end_ns, {t.name: t.message_count for t in self.topics.values()})
            return self.summary

    def _rosbag2_metadata(self) -> dict:
        start = self._start_ns or 0
        duration = max(0, self._end_ns - start) if self._start_ns is not None else 0
        count = self.message_count
        return {"rosbag2_bagfile_information": {
            "version": ROSBAG2_VERSION,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": duration},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": count,
            "topics_with_message_count": [
                {"topic_metadata": {"name": t.name, "type": t.type, "serialization_format": "cdr",
                                    "offered_qos_profiles": t.offered_qos_profiles,
                                    "type_description_hash": t.type_hash},
                 "message_count": t.message_count}
                for t in self.topics.values()],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [self.mcap_path.name],
            "files": [{"path": self.mcap_path.name, "starting_time": {"nanoseconds_since_epoch": start},
                       "duration": {"nanoseconds": duration}, "message_count": count}],
            "custom_data": {"writer": "fic_teleop fic_teleop_tools.recording.bag_writer"},
            "ros_distro": "jazzy",
        }}

    def _check_open(self) -> None:
        if self._finished:
            raise BagError(f"bag {self.bag_dir} is finished; no more writes")

    def __enter__(self) -> "BagWriter":
        return self

    def __exit__(self, *exc_info) -> None:
        self.finish()
