"""Synthetic run folders for the dataset export's tests: run.json and a bag written by the project's writer, with
every stream the export reads, each value carrying its own stamp (so a test can tell a held value from a future
one) and each stream at its own rate and phase."""
from __future__ import annotations

import json
from pathlib import Path

from rclpy.serialization import serialize_message

from fic_teleop_tools.recording.bag_writer import BagWriter

JOINTS = [f"panda_joint{i}" for i in range(1, 8)]
NOMINAL = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]
START_NS = 5_000_000_000   # the streams' clock at the run's start


def stamp_seconds(stamp_ns: int) -> float:
    """What every value of a sample stamped ``stamp_ns`` carries: its time since the run's start [s]."""
    return (stamp_ns - START_NS) * 1e-9


def write_run(folder: Path, duration_s: float = 1.0, camera_hz: float = 30.0, marks: tuple[str, ...] = (),
              finish: bool = True, camera: bool = True, scene: str = "superimposition") -> Path:
    from geometry_msgs.msg import Pose, PoseArray, PoseStamped, WrenchStamped
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    folder.mkdir(parents=True)
    (folder / "run.json").write_text(json.dumps({"scene": scene, "task": "push the box", "seed": 1}))
    writer = BagWriter(folder / "bag", chunk_size=4096)
    types = {"/joint_states": "sensor_msgs/msg/JointState", "/replica/tcp_pose": "geometry_msgs/msg/PoseStamped",
             "/haptic/pose": "geometry_msgs/msg/PoseStamped", "/replica/desired_pose": "geometry_msgs/msg/PoseStamped",
             "/ft_sensor/wrench": "geometry_msgs/msg/WrenchStamped",
             "/haptic/wrench_command": "geometry_msgs/msg/WrenchStamped", "/episode/marker": "std_msgs/msg/String"}
    if camera:
        types["/sim/object_poses"] = "geometry_msgs/msg/PoseArray"
    for topic, type_name in types.items():
        writer.add_topic(topic, type_name)
    # (topic, period [ns], phase [ns]): rates and phases that do not line up with the frames
    rates = [("/joint_states", 2_000_000, 0), ("/replica/tcp_pose", 10_000_000, 3_000_000),
             ("/haptic/pose", 4_000_000, 1_000_000), ("/replica/desired_pose", 10_000_000, 7_000_000),
             ("/ft_sensor/wrench", 4_000_000, 2_000_000), ("/haptic/wrench_command", 4_000_000, 500_000)]
    if camera:
        rates.append(("/sim/object_poses", round(1e9 / camera_hz), 4_000_000))
    messages = []
    for topic, period, phase in rates:
        stamp = START_NS + phase
        while stamp <= START_NS + duration_s * 1e9:
            messages.append((stamp, topic))
            stamp += period
    messages.sort()
    for k, (stamp, topic) in enumerate(messages):
        value = stamp_seconds(stamp)
        if topic == "/joint_states":
            message = JointState(name=JOINTS, position=[q + 0.1 * value for q in NOMINAL],
                                 velocity=[value] * 7)
        elif topic == "/sim/object_poses":
            pose = Pose()
            pose.position.x, pose.position.y, pose.position.z = 0.5 + value, 0.1, 0.05
            pose.orientation.w = 1.0
            message = PoseArray(poses=[pose])
        elif "wrench" in topic:
            message = WrenchStamped()
            message.wrench.force.x = message.wrench.torque.z = value
        else:
            message = PoseStamped()
            message.pose.position.x = message.pose.position.z = value
            message.pose.orientation.w = 1.0
        message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
        writer.write(topic, serialize_message(message), stamp)
        if k == len(messages) // 2:
            for mark in marks:
                writer.write("/episode/marker", serialize_message(String(data=mark)), stamp)
            writer.flush()
    if finish:
        writer.finish()
    return folder
