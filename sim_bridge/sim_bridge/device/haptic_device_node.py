"""ROS 2 shell around the simulated haptic device and its virtual operator (haptic_device.py, virtual_operator.py).

Speaks what a Force Dimension driver speaks, so a real sigma.7 can take its place: publishes the handle pose
x_M (/haptic/pose, frame haptic_base) and twist (/haptic/twist), takes the force command
(/haptic/wrench_command, force only). The loop is closed: the command moves the handle, integrated at the
device's 1 kHz substep between publications. The hand on the handle is the virtual operator: a scripted one
(config/operator_scripts/<scene>.yaml, which also presses buttons on /operator/joy for the master), a closed-loop
one that times its moves from the delayed video of the replica (closed_loop_operator.py: the robot's
/sim/tcp_pose and /sim/object_poses after the backward channel, on /master/video/tcp_pose and
/master/video/object_poses; the script still presses the buttons), the shape-sorting operator of E2 that watches
the same video (every piece's pose) and feels the rendered force with the force-reactive hand
(shape_sorting_operator.py, reactive_hand.py; it presses its own buttons), one steered by /operator/joy axes
(keyboard_operator or a joystick), or none (the handle is free). Time is the node clock, so use_sim_time runs the
device in the simulator's time. The device, the hand and what drives it are one object, device_station.py's
DeviceStation, which the in-process runner steps too: this node is its wiring (topics, timers, log lines).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from geometry_msgs.msg import PoseArray, PoseStamped, TwistStamped, WrenchStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState, Joy
from std_msgs.msg import Bool, Float64MultiArray

from fic_core.errors import FicInputError
from fic_teleop_runtime import qos
from fic_teleop_runtime.driver_topics import DEVICE_INTERFACES, FORCE_DIMENSION, SYSTEM_DEFAULTS_QOS
from fic_teleop_runtime.in_process_link import HANDLE_LINK
from fic_teleop_runtime.node_main import NodeEntry, run_entry
from fic_teleop_runtime.parameters import Schema, declare
from fic_teleop_runtime.periodic import PeriodicCallbacks
from fic_teleop_runtime.record_batch import BatchedPublisher
from fic_teleop_runtime.stamps import nanoseconds
from fic_teleop_runtime.workspace import config_folder
from sim_bridge.device.closed_loop_operator import ClosedLoopOperator, ClosedLoopParameters, Frame
from sim_bridge.device.device_parameters import (
    DEVICE_PARAMETERS,
    OPERATOR_SOURCES,
    DeviceNodeParameters,
    hand_parameters,
    haptic_device_parameters,
)
from sim_bridge.device.device_station import DeviceStation
from sim_bridge.device.haptic_device import HapticDevice
from sim_bridge.device.reactive_hand import ReactiveHand
from sim_bridge.device.shape_sorting_operator import ShapeSortingOperator, ShapeSortingParameters, SortingFrame
from sim_bridge.device.virtual_operator import Hand, JoyTarget, ScriptedOperator, load_script

# Device streams at 250 Hz (docs/CONVENTIONS.md): RELIABLE, written with the streams' deep writer history (a
# stalled reader loses nothing), the force command read KEEP_LAST 20 like the other streams.
DEVICE_QOS, DEVICE_WRITER_QOS = qos.STREAM, qos.STREAM_WRITER
# Button presses must not be lost (a lost toggle inverts the mode for the rest of the run): RELIABLE, deep.
JOY_QOS = qos.EVENTS

# The video the closed-loop operator watches: the robot's poses after the backward channel (the launcher adds the
# two routes to channel_backward). Both carry the capture's stamp; a frame is a TCP pose and an object array of
# one stamp.
VIDEO_TCP_TOPIC = "/master/video/tcp_pose"
VIDEO_OBJECTS_TOPIC = "/master/video/object_poses"
VIDEO_QOS = qos.STREAM
PUSHABLE_OBSTACLE_INDEX = 0   # superimposition scene: /sim/object_poses holds the pushable obstacle alone
VIDEO_PAIRING_WINDOW_NS = 1_000_000_000  # a half frame older than this has lost its other half
JOY_RATE_HZ = 50.0
LONGEST_STEP = 0.05      # [s] a clock jump (pause, sim restart) is integrated as at most this much time


SCHEMA = Schema("haptic_device.yaml", DEVICE_PARAMETERS.values())


def default_script_path(scene: str) -> Path:
    """config/operator_scripts/<scene>.yaml (fic_teleop_runtime.workspace.config_folder: the checkout's with
    scripts/env.sh, else the installed copy)."""
    path = config_folder() / "operator_scripts" / f"{scene}.yaml"
    if path.is_file():
        return path
    raise FicInputError(f"no operator script for scene {scene!r}: looked at {path}; set the script_file parameter")


class HapticDeviceNode(Node):
    def __init__(self, **node_options) -> None:  # node_options: rclpy Node keywords (node_group.py)
        super().__init__("haptic_device", **node_options)
        self._periodic = PeriodicCallbacks(self)  # timers that follow the simulated clock (periodic.py)
        # Every row with its config/haptic_device.yaml value; unknown keys refused.
        p = DeviceNodeParameters.from_values(declare(self, SCHEMA))
        parameters = haptic_device_parameters(p)
        self.device = HapticDevice(parameters)
        self.hand = Hand(hand_parameters(p))
        self.frame_id = p.frame_id
        self.command_timeout = p.command_timeout
        self.joy_timeout = p.joy_timeout
        self.source = p.operator_source
        if self.source not in OPERATOR_SOURCES:
            raise FicInputError(f"operator_source must be one of {OPERATOR_SOURCES}, got {self.source!r}")

        self.interface = p.driver_interface
        if self.interface not in DEVICE_INTERFACES:
            raise FicInputError(f"driver_interface must be one of {DEVICE_INTERFACES}, got {self.interface!r}")
        self.fd = self.interface == "forcedimension"
        self.master_in_process = p.master_in_process
        if self.fd and self.master_in_process:
            raise FicInputError("master_in_process needs driver_interface sim (the forcedimension_ros2 twin speaks "
                                "DDS as the real driver does)")
        if self.fd:
            # The forcedimension_ros2 twin: its topics, types, QoS and frame; its effort controller holds the last
            # force with no timeout (command_timeout does not apply) and renders NaN as zero force.
            fd = FORCE_DIMENSION
            self.frame_id = fd.frame
            self.pose_publisher = self.create_publisher(PoseStamped, fd.ee_pose, SYSTEM_DEFAULTS_QOS)
            self.fd_joint_publisher = self.create_publisher(JointState, fd.joint_states, SYSTEM_DEFAULTS_QOS)
            self.fd_button_publisher = self.create_publisher(Bool, fd.button, SYSTEM_DEFAULTS_QOS)
            self.fd_clutch_publisher = self.create_publisher(Bool, fd.clutch, SYSTEM_DEFAULTS_QOS)
            self.create_subscription(Float64MultiArray, fd.command, self._on_fd_command, SYSTEM_DEFAULTS_QOS)
            self.fd_joint_state = JointState(name=list(fd.joint_names))
            self.fd_button_pressed = False
        else:
            # The master reads the topic itself; the recorder its batches (record_batch.py).
            self.pose_publisher = BatchedPublisher(self, PoseStamped, "/haptic/pose", DEVICE_WRITER_QOS,
                                                   p.record_batch_period)
            self.twist_publisher = self.create_publisher(TwistStamped, "/haptic/twist", DEVICE_WRITER_QOS)
            if self.master_in_process:   # the master of this process hands its force command over (in_process_link)
                HANDLE_LINK.force_reader = self._on_command
            else:
                self.create_subscription(WrenchStamped, "/haptic/wrench_command", self._on_command, DEVICE_QOS)
        self.scripted: ScriptedOperator | None = None
        self.watcher: ClosedLoopOperator | None = None
        self.sorter: ShapeSortingOperator | None = None
        self.video_halves: dict[tuple[str, int], np.ndarray] = {}
        self.joy_target: JoyTarget | None = None
        if self.source in ("scripted", "closed_loop"):
            scene = p.scene
            if self.source == "closed_loop" and scene != "superimposition":
                raise FicInputError(f"operator_source closed_loop drives the superimposition scene only, not {scene!r}")
            path = Path(p.script_file) if p.script_file else default_script_path(scene)
            script = load_script(path)
            script.check_workspace(parameters.half_extents)
            self.scripted = ScriptedOperator(script)   # closed_loop: its button presses and its moves' numbers
            if self.source == "closed_loop":
                self.watcher = ClosedLoopOperator(ClosedLoopParameters.from_script_parameters(
                    script.parameters, reaction_time=p.reaction_time, assumed_one_way_delay=p.assumed_one_way_delay))
                self.create_subscription(PoseStamped, VIDEO_TCP_TOPIC, self._on_video_tcp, VIDEO_QOS)
                self.create_subscription(PoseArray, VIDEO_OBJECTS_TOPIC, self._on_video_objects, VIDEO_QOS)
                self.get_logger().info(
                    f"closed-loop operator: watches {VIDEO_TCP_TOPIC} and {VIDEO_OBJECTS_TOPIC}, reaction "
                    f"{p.reaction_time:.2f} s, assumed one-way delay {p.assumed_one_way_delay:.2f} s")
            self.joy_publisher = self.create_publisher(Joy, "/operator/joy", JOY_QOS)
            self._periodic.create(1.0 / JOY_RATE_HZ, self._publish_buttons)
            self.get_logger().info(f"scripted operator: {path} ({script.name}, {script.duration:.1f} s, "
                                   f"{len(script.events)} button presses)")
        elif self.source == "shape_sorting":
            if p.scene != "shape_sorting":
                raise FicInputError(f"operator_source shape_sorting drives the shape_sorting scene only, not "
                                    f"{p.scene!r}")
            # What it has learnt of the master (K0, F_max, k_v, the dead-band) is config/master.yaml's, the
            # parameters' defaults; the hand reacts to the force it feels (reactive_hand.py, its mean figures).
            self.sorter = ShapeSortingOperator(ShapeSortingParameters(
                perception_delay=p.reaction_time, assumed_one_way_delay=p.assumed_one_way_delay,
                handle_half_extents=tuple(p.half_extents)))
            self.hand = ReactiveHand(self.hand.parameters)
            self.create_subscription(PoseStamped, VIDEO_TCP_TOPIC, self._on_video_tcp, VIDEO_QOS)
            self.create_subscription(PoseArray, VIDEO_OBJECTS_TOPIC, self._on_video_objects, VIDEO_QOS)
            self.joy_publisher = self.create_publisher(Joy, "/operator/joy", JOY_QOS)
            self._periodic.create(1.0 / JOY_RATE_HZ, self._publish_buttons)
            self.get_logger().info(
                f"shape-sorting operator: watches {VIDEO_TCP_TOPIC} and {VIDEO_OBJECTS_TOPIC}, perception "
                f"{p.reaction_time:.2f} s, assumed one-way delay {p.assumed_one_way_delay:.2f} s")
        elif self.source == "joy":
            self.joy_target = JoyTarget(parameters.half_extents, max_speed=p.joy_max_speed)
            self.create_subscription(Joy, "/operator/joy", self._on_joy, JOY_QOS)
            self.get_logger().info("operator steered by /operator/joy axes 0..2")
        else:
            self.get_logger().info("no operator: the handle moves under the force command alone")

        now = self._now()
        start = p.script_start_time
        self.script_origin = now if start < 0.0 else start
        self.last_time = now
        # forcedimension_ros2's effort controller holds the last force with no timeout.
        self.station = DeviceStation(self.device, self.hand, script=self.scripted, watcher=self.watcher or self.sorter,
                                     joy_target=self.joy_target,
                                     command_timeout=None if self.fd else self.command_timeout,
                                     joy_timeout=self.joy_timeout, script_origin=self.script_origin,
                                     quiet_from=p.quiet_from if p.quiet_from >= 0.0 else None)
        self._periodic.create(1.0 / p.publish_rate_hz, self._tick)

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # -- inputs ---------------------------------------------------------------------------------------------
    def _on_command(self, message: WrenchStamped) -> None:
        force = np.array([message.wrench.force.x, message.wrench.force.y, message.wrench.force.z])
        if not np.all(np.isfinite(force)):
            self.get_logger().error(f"refused /haptic/wrench_command with a non-finite force {force.tolist()}",
                                    throttle_duration_sec=1.0)
            return
        if self.station.command(force, self._now()):
            self.get_logger().info("force commands are fresh again")

    def _on_fd_command(self, message: Float64MultiArray) -> None:
        """forcedimension_ros2's write(): the first three entries are the force in fd_base; a NaN anywhere renders
        zero force; the last command stays until another comes."""
        data = list(message.data)
        if len(data) < 3:
            self.get_logger().error(f"refused {FORCE_DIMENSION.command}: {len(data)} values, need at least 3",
                                    throttle_duration_sec=1.0)
            return
        force = np.array(data[:3], dtype=float)
        self.station.command(force if np.all(np.isfinite(data)) else np.zeros(3), self._now())

    def _on_video_tcp(self, message: PoseStamped) -> None:
        p = message.pose.position
        self._video_half("tcp", nanoseconds(message.header.stamp), np.array([p.x, p.y, p.z]))

    def _on_video_objects(self, message: PoseArray) -> None:
        if self.sorter is not None:   # every piece, in the scene's order (scenes.SHAPE_SORTING_PIECES)
            pieces = np.array([[pose.position.x, pose.position.y, pose.position.z] for pose in message.poses])
            self._video_half("objects", nanoseconds(message.header.stamp), pieces.reshape(-1, 3))
            return
        if len(message.poses) <= PUSHABLE_OBSTACLE_INDEX:
            self.get_logger().error(f"refused {VIDEO_OBJECTS_TOPIC} with {len(message.poses)} poses: the "
                                    "superimposition scene has the pushable obstacle", throttle_duration_sec=1.0)
            return
        p = message.poses[PUSHABLE_OBSTACLE_INDEX].position
        self._video_half("objects", nanoseconds(message.header.stamp), np.array([p.x, p.y, p.z]))

    def _video_half(self, kind: str, stamp_ns: int, position: np.ndarray) -> None:
        """A frame is shown once both halves of one capture have arrived (the channel delivers them apart)."""
        if not np.all(np.isfinite(position)):
            self.get_logger().error(f"refused a video {kind} pose that is not finite", throttle_duration_sec=1.0)
            return
        other = self.video_halves.pop(("objects" if kind == "tcp" else "tcp", stamp_ns), None)
        if other is None:
            self.video_halves[(kind, stamp_ns)] = position
            for key in [key for key in self.video_halves if key[1] < stamp_ns - VIDEO_PAIRING_WINDOW_NS]:
                del self.video_halves[key]
            return
        tcp, objects = (position, other) if kind == "tcp" else (other, position)
        if self.sorter is None:
            self.watcher.see(self._now(), Frame(stamp_ns * 1e-9, tcp, objects))
            return
        try:
            self.sorter.see(self._now(), SortingFrame(stamp_ns * 1e-9, tcp, objects))
        except FicInputError as error:
            self.get_logger().error(f"refused a video frame: {error}", throttle_duration_sec=1.0)

    def _on_joy(self, message: Joy) -> None:
        axes = list(message.axes[:3])
        if not all(math.isfinite(a) for a in axes):
            self.get_logger().error("refused /operator/joy with non-finite axes", throttle_duration_sec=1.0)
            return
        self.station.axes(axes, self._now())

    # -- loop -----------------------------------------------------------------------------------------------
    def _tick(self) -> None:
        now = self._now()
        dt = min(max(now - self.last_time, 0.0), LONGEST_STEP)
        self.last_time = now
        step = self.station.update(now, dt)
        if step.stale_now:
            # Once per stale episode, not every tick: a lost master makes the handle go limp, which is safe.
            self.get_logger().warning(f"force command stale (older than {self.command_timeout:.3f} s): "
                                      "rendering zero force")
        for move in step.moves:
            if self.sorter is not None:
                phase, start, figure = move
                self.get_logger().info(f"shape-sorting operator: {phase} at {start:.3f} s ({figure:.4g})")
            else:
                name, start, passing = move
                self.get_logger().info(f"closed-loop operator starts its {name} move at {start:.2f} s for the "
                                       f"passing it predicts at {passing:.2f} s")
        if self.fd and (self.scripted is not None or self.sorter is not None):
            self._fd_buttons()
        state, command = step.state, step.command
        stamp = self.get_clock().now().to_msg()
        pose = PoseStamped()
        pose.header.stamp, pose.header.frame_id = stamp, self.frame_id
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = (float(v) for v in state.position)
        pose.pose.orientation.w = 1.0        # translational device: the handle's orientation is not modelled
        if self.fd:
            self.pose_publisher.publish(pose)
            joints = self.fd_joint_state
            joints.header.stamp = stamp
            joints.position = [float(v) for v in state.position]
            joints.velocity = [float(v) for v in state.velocity]
            joints.effort = [float(v) for v in command]
            self.fd_joint_publisher.publish(joints)
            self.fd_button_publisher.publish(Bool(data=self.fd_button_pressed))
            self.fd_clutch_publisher.publish(Bool(data=True))  # workspace engaged (no clutch modelled)
            return
        twist = TwistStamped()
        twist.header.stamp, twist.header.frame_id = stamp, self.frame_id
        twist.twist.linear.x, twist.twist.linear.y, twist.twist.linear.z = (float(v) for v in state.velocity)
        master = HANDLE_LINK if self.master_in_process else None
        if master is not None and master.pose_reader is not None:   # the master's inputs, here in the tick
            master.pose_reader(pose)
            master.twist_reader(twist)
        self.pose_publisher.publish(pose)
        if master is None or self.twist_publisher.get_subscription_count():  # linked: only the master read it
            self.twist_publisher.publish(twist)

    def _fd_buttons(self) -> None:
        """The device's one button carries the script's mode toggles (held for one publication, released for
        the next, so two toggles stay two); the other scripted presses still go to /operator/joy."""
        if self.fd_button_pressed:
            self.fd_button_pressed = False
            return
        if self.station.buttons and self.station.buttons[0] == 0:
            self.station.buttons.popleft()
            self.fd_button_pressed = True
            self.get_logger().info("operator presses the device button")

    def _publish_buttons(self) -> None:
        """Edge-triggered presses: one Joy message with the button at 1, then one with all at 0, so two presses
        of the same button in a row stay two presses; nothing while nothing changes (DeviceStation.button_states)."""
        buttons = self.station.button_states(skip_first=self.fd)
        if buttons is None:
            return
        message = Joy()
        message.header.stamp = self.get_clock().now().to_msg()
        message.axes = [0.0, 0.0, 0.0]
        message.buttons = buttons
        if any(buttons):
            self.get_logger().info(f"operator presses button {buttons.index(1)}")
        self.joy_publisher.publish(message)


def main(args: list[str] | None = None) -> None:
    run_entry(ENTRY, args)


ENTRY = NodeEntry(HapticDeviceNode, "haptic_device", follow_sim_time=False)  # its timers: periodic.py


if __name__ == "__main__":
    main()
