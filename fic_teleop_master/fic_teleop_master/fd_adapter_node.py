"""forcedimension_ros2 adapter: a Force Dimension device (Omega.3/6/7, Falcon) in front of the master.

    /fd/ee_pose (PoseStamped, fd_base) ----------------> /haptic/pose  (x_M, haptic_base)
    /fd/joint_states (fd_x, fd_y, fd_z velocities) ----> /haptic/twist (xd_M, haptic_base)
    /haptic/wrench_command (f, haptic_base) -----------> /fd/fd_controller/commands (Float64MultiArray, fd_base)
    /fd/button_state (Bool) ---------------------------> /operator/joy button 0 on a rising edge (the master's
                                                          mode toggle), or button 3 held (the master's clutch)
    /fd/fd_clutch (Bool, true: workspace engaged) ------> /operator/joy button 3 held while false (the clutch)
    grasp DoF (joint ``grasp_joint`` of /fd/joint_states, an Omega.7's gripper angle) -> /master/haptic_gain

The arithmetic (frames, the grasp gain, the command layout) is fic_core.haptic_device_mapping; the topics, types
and QoS are the driver's (docs/HARDWARE.md cites its sources). The driver publishes at its controller manager's
rate (1 kHz by default); the master's inputs are forwarded at ``publish_rate_hz`` with the newest values.

Safety: forcedimension_ros2's effort controller applies the last force it received for as long as nobody sends
another. So the adapter ramps the device force to zero over ``force_ramp_time`` when the master's force goes
stale (``command_timeout``) and when the handle's pose stops (``pose_timeout``; it then also stops forwarding
x_M, so the master renders zero force and keeps commanding the last x_d': the replica holds its pose). Each
transition is one log line. A pose in another frame than ``device_frame`` is refused (one log line, throttled).
"""
from __future__ import annotations

import math

import numpy as np
import rclpy
from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState, Joy
from std_msgs.msg import Bool, Float64, Float64MultiArray

from fic_core.errors import FicInputError
from fic_core.haptic_device_mapping import DeviceFrameMapping, GraspGain, device_command
from fic_core.operator_buttons import BUTTON_COUNT, OperatorButton
from fic_core.parameter_row import parameter_set
from fic_core.stale_input_ramp import StaleInputRamp
from fic_teleop_runtime import qos
from fic_teleop_runtime.node_main import NodeEntry, run_entry
from fic_teleop_runtime.parameters import Schema, declare, integer, number, numbers, switch, text, texts

NODE_NAME = "fd_adapter"
#: What forcedimension_ros2's broadcasters and its effort controller use: rclcpp::SystemDefaultsQoS(); the
#: adapter's own view of the 1 kHz driver streams: only the newest matters (best effort matches reliable); the
#: master's streams and buttons as the master reads them (written with the streams' deep writer history).
DRIVER_QOS, NEWEST_QOS, STREAM_QOS, JOY_QOS = qos.SYSTEM_DEFAULTS, qos.NEWEST, qos.STREAM, qos.EVENTS
STREAM_WRITER_QOS = qos.STREAM_WRITER
BUTTON_ACTIONS = ("toggle_mode", "clutch")
LOG_THROTTLE_S = 2.0


#: Every parameter is fixed at start (the device does not change under a running adapter); their values are the
#: profile's, config/profiles/forcedimension/fd_adapter.yaml.
SCHEMA = Schema(
    "profiles/forcedimension/fd_adapter.yaml",
    text("device_frame", "frame_id of /fd/ee_pose (the driver's)", read_only=True),
    text("master_frame", "frame_id of /haptic/pose and /haptic/twist", read_only=True),
    numbers("rotation", "quaternion x, y, z, w of haptic_base <- fd_base (identity: the SDK's axes are the "
                        "master's)", read_only=True),
    numbers("workspace_centre", "the handle position that is x_M = 0, in fd_base [m] (the SDK's origin is the "
                                "workspace centre)", read_only=True),
    texts("translation_joints", "names of the handle's translation joints in /fd/joint_states (their velocities "
                                "are xd_M)", read_only=True),
    text("grasp_joint", "joint of /fd/joint_states whose angle sets K_H (an Omega.7's gripper: fd_clutch); "
                        "empty: none", read_only=True),
    number("grasp_open_angle", -10.0, 10.0, "gripper angle giving K_H = 0 [rad]", True),
    number("grasp_closed_angle", -10.0, 10.0, "angle giving grasp_max_gain [rad]", True),
    number("grasp_max_gain", 0.0, 1.0, "K_H with the gripper closed", True),
    switch("use_clutch", "map /fd/fd_clutch to the master's clutch (an Omega.6/7's): engaged (true) drives x_d', "
                         "released holds it still while the handle moves", read_only=True),
    text("button_action", "what the device's button does: toggle_mode (a press toggles the master's offset/velocity "
                          "mode) or clutch (held: the master's clutch)", read_only=True),
    integer("command_size", 3, 7, "entries of the driver's effort controller (its joints: 3 fd_x..z, 6 with the "
                                  "wrist, 7 with the gripper); force first, zeros after", True),
    number("max_force", 0.0, 100.0, "device force norm bound [N]; 0: none", True),
    number("publish_rate_hz", 1.0, 2000.0, "/haptic/pose and /haptic/twist rate (newest values) [Hz]", True),
    number("pose_timeout", 0.001, 10.0, "no /fd/ee_pose for this long: stop forwarding x_M, ramp the force to "
                                        "zero [s]", True),
    number("command_timeout", 0.001, 10.0, "no /haptic/wrench_command for this long: ramp the force to zero [s]",
           True),
    number("force_ramp_time", 0.0, 10.0, "duration of the ramp to zero force [s]", True),
)
#: The adapter's parameters as one typed object, one field a row of SCHEMA (fic_core.parameter_row): a name no row
#: has is refused where it is built, naming the nearest.
FdAdapterParameters = parameter_set("FdAdapterParameters", __name__, "fd adapter", SCHEMA.rows,
                                    "The fd adapter's parameters (SCHEMA), checked, one field a row.")


class FdAdapterNode(Node):
    def __init__(self, **node_options) -> None:  # node_options: rclpy Node keywords (node_group.py)
        super().__init__(NODE_NAME, **node_options)
        # Every row with its profile value (unknown keys refused), as one typed object.
        p = FdAdapterParameters.from_values(declare(self, SCHEMA))
        self._device_frame = p.device_frame
        self._master_frame = p.master_frame
        self._mapping = DeviceFrameMapping(p.rotation, p.workspace_centre)
        self._translation_joints = tuple(p.translation_joints)
        if len(self._translation_joints) != 3:
            raise FicInputError(f"translation_joints must name 3 joints, got {list(self._translation_joints)}")
        self._grasp_joint = p.grasp_joint
        self._grasp = GraspGain(p.grasp_open_angle, p.grasp_closed_angle, p.grasp_max_gain)
        self._button_action = p.button_action
        if self._button_action not in BUTTON_ACTIONS:
            raise FicInputError(f"button_action must be one of {', '.join(BUTTON_ACTIONS)}, got "
                                f"{self._button_action!r}")
        self._command_size = p.command_size
        self._max_force = p.max_force
        self._pose_ramp = StaleInputRamp(p.pose_timeout, p.force_ramp_time)
        self._command_ramp = StaleInputRamp(p.command_timeout, p.force_ramp_time)

        self._position: np.ndarray | None = None     # x_M, newest
        self._velocity = np.zeros(3)                 # xd_M, newest
        self._stamp = None
        self._force = np.zeros(3)                    # last force sent, device frame
        self._button = False
        self._clutch_held = False                    # the level of /operator/joy's clutch button
        self._haptic_gain: float | None = None       # last K_H sent
        self._joint_index: dict[tuple[str, ...], tuple[list[int], int | None]] = {}
        self.counts = {"poses": 0, "refused_poses": 0, "joint_states": 0, "refused_joint_states": 0,
                       "commands": 0, "refused_commands": 0, "mode_toggles": 0, "clutch_changes": 0, "gain_changes": 0,
                       "ramps": 0}

        self._pose_pub = self.create_publisher(PoseStamped, "/haptic/pose", STREAM_WRITER_QOS)
        self._twist_pub = self.create_publisher(TwistStamped, "/haptic/twist", STREAM_WRITER_QOS)
        self._device_pub = self.create_publisher(Float64MultiArray, "/fd/fd_controller/commands", DRIVER_QOS)
        self._joy_pub = self.create_publisher(Joy, "/operator/joy", JOY_QOS)
        self._gain_pub = self.create_publisher(Float64, "/master/haptic_gain", STREAM_WRITER_QOS)
        self.create_subscription(PoseStamped, "/fd/ee_pose", self._on_pose, NEWEST_QOS)
        self.create_subscription(JointState, "/fd/joint_states", self._on_joint_state, NEWEST_QOS)
        # Button and clutch are events: reliable, as the driver publishes them, so an edge is not lost.
        self.create_subscription(Bool, "/fd/button_state", self._on_button, DRIVER_QOS)
        if p.use_clutch:
            self.create_subscription(Bool, "/fd/fd_clutch", self._on_clutch, DRIVER_QOS)
        self.create_subscription(WrenchStamped, "/haptic/wrench_command", self._on_wrench_command, STREAM_QOS)
        self.create_timer(1.0 / p.publish_rate_hz, self._tick)
        self.get_logger().info(
            f"fd adapter ready: {self._device_frame} -> {self._master_frame}, force to /fd/fd_controller/commands "
            f"({self._command_size} entries), grasp joint {self._grasp_joint or 'none'}, pose_timeout "
            f"{p.pose_timeout:g} s, command_timeout {p.command_timeout:g} s")

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # -- device -> master ---------------------------------------------------------------------------------------
    def _on_pose(self, message: PoseStamped) -> None:
        if message.header.frame_id != self._device_frame:
            self.counts["refused_poses"] += 1
            self.get_logger().error(f"refused /fd/ee_pose in frame {message.header.frame_id!r}, expected "
                                    f"{self._device_frame!r}", throttle_duration_sec=LOG_THROTTLE_S)
            return
        p = message.pose.position
        try:
            self._position = self._mapping.position_to_master([p.x, p.y, p.z])
        except FicInputError as exc:
            self.counts["refused_poses"] += 1
            self.get_logger().error(f"refused /fd/ee_pose: {exc}", throttle_duration_sec=LOG_THROTTLE_S)
            return
        self.counts["poses"] += 1
        self._stamp = message.header.stamp
        if self._pose_ramp.fresh(self._now()):
            self.get_logger().warning("/fd/ee_pose is back: forwarding x_M again")

    def _on_joint_state(self, message: JointState) -> None:
        key = tuple(message.name)
        found = self._joint_index.get(key)
        if found is None:
            try:
                found = ([key.index(name) for name in self._translation_joints],
                         key.index(self._grasp_joint) if self._grasp_joint in key else None)
            except ValueError:
                self.counts["refused_joint_states"] += 1
                self.get_logger().error(f"refused /fd/joint_states: expected {list(self._translation_joints)}, "
                                        f"received {list(key)}", throttle_duration_sec=LOG_THROTTLE_S)
                return
            self._joint_index[key] = found
        translation, grasp = found
        if len(message.velocity) != len(key):
            self.counts["refused_joint_states"] += 1
            self.get_logger().error(f"refused /fd/joint_states: {len(key)} names, {len(message.velocity)} "
                                    "velocities", throttle_duration_sec=LOG_THROTTLE_S)
            return
        try:
            self._velocity = self._mapping.velocity_to_master([message.velocity[i] for i in translation])
            if grasp is not None and self._grasp_joint and len(message.position) == len(key):
                self._set_haptic_gain(self._grasp.haptic_gain(message.position[grasp]), "grasp")
        except FicInputError as exc:
            self.counts["refused_joint_states"] += 1
            self.get_logger().error(f"refused /fd/joint_states: {exc}", throttle_duration_sec=LOG_THROTTLE_S)
            return
        self.counts["joint_states"] += 1

    def _on_button(self, message: Bool) -> None:
        pressed = bool(message.data)
        if self._button_action == "clutch":
            self._set_clutch(pressed, "button")
        elif pressed and not self._button:  # the master toggles on a rising edge of its button 0
            self.counts["mode_toggles"] += 1
            self._publish_joy(toggle=True)
        elif not pressed and self._button:
            self._publish_joy()
        self._button = pressed

    def _on_clutch(self, message: Bool) -> None:
        self._set_clutch(not message.data, "fd_clutch")   # fd_clutch true: the workspace is engaged

    def _set_clutch(self, held: bool, source: str) -> None:
        if held == self._clutch_held:
            return
        self._clutch_held = held
        self.counts["clutch_changes"] += 1
        self._publish_joy()
        self.get_logger().info(f"clutch {'held' if held else 'released'} ({source})")

    def _set_haptic_gain(self, gain: float, source: str) -> None:
        if self._haptic_gain is not None and abs(gain - self._haptic_gain) < 0.01:
            return
        self._haptic_gain = gain
        self.counts["gain_changes"] += 1
        self._gain_pub.publish(Float64(data=float(gain)))
        self.get_logger().info(f"K_H = {gain:.2f} ({source})", throttle_duration_sec=0.5)

    def _publish_joy(self, toggle: bool = False) -> None:
        """The master's buttons: the mode toggle pressed or not, the clutch at its level in every message (the
        master acts on each button's edges)."""
        buttons = [0] * BUTTON_COUNT
        buttons[OperatorButton.TOGGLE_MODE] = int(toggle)
        buttons[OperatorButton.CLUTCH] = int(self._clutch_held)
        joy = Joy()
        joy.header.stamp = self.get_clock().now().to_msg()
        joy.axes = [0.0, 0.0, 0.0]
        joy.buttons = buttons
        self._joy_pub.publish(joy)

    # -- master -> device ---------------------------------------------------------------------------------------
    def _on_wrench_command(self, message: WrenchStamped) -> None:
        f = message.wrench.force
        if not all(math.isfinite(v) for v in (f.x, f.y, f.z)):
            self.counts["refused_commands"] += 1
            self.get_logger().error("refused /haptic/wrench_command with a non-finite force",
                                    throttle_duration_sec=LOG_THROTTLE_S)
            return
        now = self._now()
        if self._command_ramp.fresh(now):
            self.get_logger().warning("/haptic/wrench_command is back: rendering the master's force again")
        if self._pose_ramp.stale:
            return  # the handle is not tracked: the ramp to zero force goes on
        self.counts["commands"] += 1
        self._send_force(self._mapping.force_to_device([f.x, f.y, f.z]))

    def _send_force(self, force: np.ndarray) -> None:
        self._force = np.asarray(force, dtype=float)
        self._device_pub.publish(Float64MultiArray(data=device_command(self._force, self._command_size,
                                                                       self._max_force)))

    def _tick(self) -> None:
        now = self._now()
        for ramp, what in ((self._pose_ramp, f"no /fd/ee_pose for more than {self._pose_ramp.timeout:g} s: "
                                             "x_M is no longer forwarded (the master renders zero force and the "
                                             "replica holds its last x_d')"),
                           (self._command_ramp, f"no /haptic/wrench_command for more than "
                                                f"{self._command_ramp.timeout:g} s")):
            if ramp.check(now, self._force):
                self.counts["ramps"] += 1
                self.get_logger().error(f"{what}; ramping the device force to zero over {ramp.ramp_time:g} s "
                                        "(the driver would hold the last force)")
        if self._pose_ramp.stale or self._command_ramp.stale:
            ramp = self._pose_ramp if self._pose_ramp.stale else self._command_ramp
            self._send_force(ramp.command(now, np.zeros(3)))
        if self._position is None or self._pose_ramp.stale:
            return
        stamp = self._stamp
        pose = PoseStamped()
        pose.header.stamp, pose.header.frame_id = stamp, self._master_frame
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = (float(v) for v in self._position)
        pose.pose.orientation.w = 1.0
        twist = TwistStamped()
        twist.header.stamp, twist.header.frame_id = stamp, self._master_frame
        twist.twist.linear.x, twist.twist.linear.y, twist.twist.linear.z = (float(v) for v in self._velocity)
        self._pose_pub.publish(pose)
        self._twist_pub.publish(twist)


def main(args: list[str] | None = None) -> None:
    run_entry(ENTRY, args)


ENTRY = NodeEntry(FdAdapterNode, NODE_NAME, stopped=lambda node: rclpy.logging.get_logger(NODE_NAME).info(
    f"fd adapter stopped: {node.counts}"))


if __name__ == "__main__":
    main()
