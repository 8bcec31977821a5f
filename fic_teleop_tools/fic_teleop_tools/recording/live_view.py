"""The live view: the graph's topics on a Foxglove WebSocket server while a run records (docs/TOOLS.md).

The recorder already holds every topic's CDR bytes and its ros2msg definition, so the view is served from the
recorder process (`live_port` > 0): each recorded topic becomes a channel with the same schema (encoding
"ros2msg") and the same CDR payloads, so Foxglove or Lichtblick decode them as they would a rosbag2 MCAP file.
A view needs far less than the control rate: a topic is sent at most `view_rate` times a second (newest
message first, the others skipped), and only while a client is subscribed to it.

tf2 is not a wheel, so the arm's pose goes out in the SDK's own schema: `/live/transforms`
(foxglove.FrameTransforms, protobuf) gives every Panda link in `panda_link0`, computed by Pinocchio's forward
kinematics on the newest joint state (the very URDF the simulator and the replica load). The URDF itself is
on `/robot_description` (std_msgs/msg/String, like robot_state_publisher's) and, with its meshes, through the
server's asset handler under `package://example-robot-data/...`, which the 3D panel's URDF layer fetches.

The server binds to 127.0.0.1 unless told otherwise: the graph's data is not for the network by default.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import foxglove
import numpy as np
from foxglove.channels import FrameTransformsChannel
from foxglove.messages import FrameTransform, FrameTransforms, Quaternion, Timestamp, Vector3
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from fic_core.panda_description import ARM_JOINT_NAMES, panda_description

TRANSFORMS_TOPIC = "/live/transforms"
ROBOT_DESCRIPTION_TOPIC = "/robot_description"
BASE_FRAME = "panda_link0"
# The URDF's mesh URIs are package://example-robot-data/robots/panda_description/meshes/...
ASSET_PACKAGE = "example-robot-data"
STRING_DEFINITION = "string data"


class LiveViewError(RuntimeError):
    """The live view could not start (the port is taken, the host cannot be bound)."""


# The middleware's own CDR (de)serialisation (rclpy.serialization over the messages' type support): the view runs in
# the recorder, an rclpy node, and reads exactly what Fast DDS wrote, padding included, with no decoder of our own.


def _cdr_string(text: str) -> bytes:
    """std_msgs/msg/String in CDR."""
    return serialize_message(String(data=text))


def joint_positions(cdr: bytes, names: tuple[str, ...] = ARM_JOINT_NAMES) -> np.ndarray | None:
    """The arm's joint positions, in `names` order, from a sensor_msgs/msg/JointState CDR message; None if a joint
    is missing."""
    state = deserialize_message(cdr, JointState)
    index = {name: i for i, name in enumerate(state.name)}
    if any(name not in index for name in names) or len(state.position) != len(state.name):
        return None
    return np.array([state.position[index[name]] for name in names], dtype=float)


class ArmTransforms:
    """Every link frame of the Panda in the base frame, from the arm's joint positions (Pinocchio)."""

    def __init__(self) -> None:
        import pinocchio as pin

        from fic_core.panda_description import load_pinocchio_model

        self._pin = pin
        self.model, self.data, _ = load_pinocchio_model()
        self.frames = [(frame.name, index) for index, frame in enumerate(self.model.frames)
                       if frame.type == pin.FrameType.BODY and frame.name != BASE_FRAME]

    def transforms(self, q: np.ndarray, stamp_ns: int) -> FrameTransforms:
        self._pin.framesForwardKinematics(self.model, self.data, q)
        stamp = Timestamp(sec=stamp_ns // 1_000_000_000, nsec=stamp_ns % 1_000_000_000)
        out = []
        for name, index in self.frames:
            placement = self.data.oMf[index]
            x, y, z, w = self._pin.Quaternion(placement.rotation).coeffs()  # Eigen's order: x, y, z, w
            t = placement.translation
            out.append(FrameTransform(timestamp=stamp, parent_frame_id=BASE_FRAME, child_frame_id=name,
                                      translation=Vector3(x=t[0], y=t[1], z=t[2]),
                                      rotation=Quaternion(x=x, y=y, z=z, w=w)))
        return FrameTransforms(transforms=out)


def asset_reader(package: str, root: Path) -> Callable[[str], bytes | None]:
    """Serve package://<package>/<path> from files under `root` only (no other file of the machine)."""
    prefix = f"package://{package}/"
    root = root.resolve()

    def read(uri: str) -> bytes | None:
        if not uri.startswith(prefix):
            return None
        path = (root / uri[len(prefix):]).resolve()
        if root not in path.parents or not path.is_file():
            return None
        return path.read_bytes()
    return read


@dataclass
class _Topic:
    channel: foxglove.Channel
    period_ns: int
    last_ns: int = -(1 << 62)


class _Subscriptions:
    """Counts the clients' subscriptions by topic (the server's listener; called from its own thread)."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.by_topic: dict[str, int] = {}
        self.new_description_subscriber = threading.Event()

    def on_subscribe(self, client, channel) -> None:
        with self.lock:
            self.by_topic[channel.topic] = self.by_topic.get(channel.topic, 0) + 1
        if channel.topic == ROBOT_DESCRIPTION_TOPIC:
            self.new_description_subscriber.set()

    def on_unsubscribe(self, client, channel) -> None:
        with self.lock:
            self.by_topic[channel.topic] = max(0, self.by_topic.get(channel.topic, 0) - 1)


class LiveView:
    """A Foxglove WebSocket server fed with raw CDR messages. `offer` is called from one thread (the recorder's
    writer thread); the server sends from its own threads."""

    def __init__(self, *, host: str = "127.0.0.1", port: int = 8765, view_rate: float = 30.0,
                 joint_states_topic: str = "/joint_states", name: str = "fic_teleop") -> None:
        self.context = foxglove.Context()
        self._period_ns = round(1e9 / view_rate)
        self._joint_states_topic = joint_states_topic
        self._topics: dict[str, _Topic] = {}
        self._subscriptions = _Subscriptions()
        description = panda_description()
        self._urdf = description.urdf_path.read_text()
        self.sent = 0
        self.skipped = 0
        try:
            self.server = foxglove.start_server(
                name=name, host=host, port=port, context=self.context, server_listener=self._subscriptions,
                asset_handler=asset_reader(ASSET_PACKAGE, description.package_dir.parent.parent))
        except RuntimeError as error:  # the SDK's FoxgloveError: "Failed to bind port: Address already in use"
            raise LiveViewError(f"cannot serve the live view on {host}:{port}: {error}") from error
        self.port = self.server.port
        self.arm = ArmTransforms()
        self._transforms = FrameTransformsChannel(TRANSFORMS_TOPIC, context=self.context)
        self._description = foxglove.Channel(
            ROBOT_DESCRIPTION_TOPIC, message_encoding="cdr", context=self.context,
            schema=foxglove.Schema(name="std_msgs/msg/String", encoding="ros2msg", data=STRING_DEFINITION.encode()))
        self._last_transforms_ns = -(1 << 62)

    def add_topic(self, topic: str, type_name: str, definition: str) -> None:
        """Advertise a topic with its ros2msg definition (the text the bag's schema holds)."""
        if topic in self._topics or not definition:
            return
        channel = foxglove.Channel(topic, message_encoding="cdr", context=self.context,
                                   schema=foxglove.Schema(name=type_name, encoding="ros2msg",
                                                          data=definition.encode()))
        self._topics[topic] = _Topic(channel, self._period_ns)

    def offer(self, topic: str, data: bytes, log_time_ns: int) -> None:
        """Send the message if a client wants the topic and the topic's view period has passed."""
        if self._subscriptions.new_description_subscriber.is_set():
            self._subscriptions.new_description_subscriber.clear()
            self._description.log(_cdr_string(self._urdf), log_time=log_time_ns)
        if topic == self._joint_states_topic and log_time_ns - self._last_transforms_ns >= self._period_ns \
                and self._transforms.has_sinks():
            q = joint_positions(data)
            if q is not None:
                self._last_transforms_ns = log_time_ns
                self._transforms.log(self.arm.transforms(q, log_time_ns), log_time=log_time_ns)
        entry = self._topics.get(topic)
        if entry is None:
            return
        if log_time_ns - entry.last_ns < entry.period_ns or not entry.channel.has_sinks():
            self.skipped += 1
            return
        entry.last_ns = log_time_ns
        entry.channel.log(data, log_time=log_time_ns)
        self.sent += 1

    def stop(self) -> None:
        self.server.stop()


def port_in_use(host: str, port: int) -> str | None:
    """Why the live view could not bind `host:port` (e.g. "Address already in use"), or None if it can."""
    import socket

    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as a server binds: TIME_WAIT is no obstacle
        try:
            probe.bind((host, port))
        except OSError as error:
            return error.strerror or str(error)
    return None
