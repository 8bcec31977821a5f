"""ROS 2 shell around fic_core's replica loop (paper Eq. 7 + postural optimisation; fic_core.replica_loop).

Data path (docs/CONVENTIONS.md):
    /joint_states (1 kHz)  ---------------------------------\\
    /replica/teleop_command (x_d', delayed by the channel) --+--> fic_core.ReplicaLoop: x_d = x_d' + x_d'',
    /planner/desired_pose, /planner/desired_accel (x_d'') ---/    ReplicaController, torque slew
    /effort_controller/commands (7 torques) <-------------------------------------------------/
    /ft_sensor/wrench (F_R) --> /replica/feedback_wrench (pose_rate, to the channel and the master)

This node declares the parameters (fic_core.replica_parameters), turns messages into the loop's calls, publishes
what the loop returns, and logs its notices. Every rule (the control grid, the holds of x_d' and x_d'', the
watchdog and its give-back, the slew at the torque-rate limit) lives in fic_core. Messages with NaN/Inf are
refused (throttled error log) and the last good value is kept; parameters are checked at start and when changed.
"""
from __future__ import annotations

import time as time_module

import numpy as np
import pinocchio as pin
import rclpy
from rclpy.serialization import deserialize_message
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from fic_teleop_msgs.msg import FicState, LimitStatus, TeleoperationCommand
from geometry_msgs.msg import AccelStamped, PoseStamped, WrenchStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from rclpy.clock import Clock, ClockType

from fic_core.errors import FicInputError
from fic_core.robot_model import RobotModel
from fic_core.replica_loop import ReplicaLoop
from fic_core.replica_parameters import REPLICA_LOOP_PARAMETERS
from fic_teleop_replica.driver_interface import DriverInterface
from fic_teleop_replica.input_guard import InputGuard
from fic_teleop_replica.schema import SCHEMA
from fic_teleop_runtime import qos
from fic_teleop_runtime.cdr_header import header_stamp, stamp_seconds
from fic_teleop_runtime.geometry import xyz, xyzw
from fic_teleop_runtime.stamps import nanoseconds, seconds, time_message
from fic_teleop_runtime.node_main import run_node
from fic_teleop_runtime.parameters import declare

# The robot-side QoS (fic_teleop_runtime.qos): the command RELIABLE for the recorder, joint states and F_R the
# newest only (no backlog of old states to the law), set-points depth 1 (only the newest is used).
ROBOT_STREAM_QOS, NEWEST_STATE_QOS, TELEOP_QOS = qos.ROBOT_STREAM, qos.NEWEST, qos.SET_POINT
STATUS_QOS, DIAGNOSTICS_QOS = qos.STREAM, qos.DIAGNOSTICS

NODE_NAME = "replica"
LOG_THROTTLE_S = 2.0


class ReplicaNode(Node):
    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        values = declare(self, SCHEMA)  # every row with its config/replica.yaml value; unknown keys refused
        # The driver behind the topics: arm, joint names, gravity semantics, wrench frame, ramp-down (docs/HARDWARE.md).
        self._driver = DriverInterface(values)
        robot = RobotModel()
        self._loop = ReplicaLoop({name: values[name] for name in REPLICA_LOOP_PARAMETERS}, robot,
                                 self._driver.limits(robot))  # FicInputError if bad
        self._joints = self._driver.joint_order
        self._wrench: WrenchStamped | None = None  # F_R as last received
        self._published: np.ndarray | None = None  # the last command sent
        self._refusal_logged: dict[str, float] = {}  # topic -> monotonic time of its last refusal line
        # What an outside input may ask of the arm (fic_core.input_authority): bounded commands, one writer per
        # robot stream; a breach holds the arm and is said at once on /diagnostics.
        self._input_guard = InputGuard(self, values, on_hold=lambda: self._publish_diagnostics())
        self.add_on_set_parameters_callback(self._on_set_parameters)

        self._command_pub = self.create_publisher(Float64MultiArray, "/effort_controller/commands", ROBOT_STREAM_QOS)
        self._fic_state_pub = self.create_publisher(FicState, "/replica/fic_state", STATUS_QOS)
        self._limit_status_pub = self.create_publisher(LimitStatus, "/replica/limit_status", STATUS_QOS)
        self._desired_pose_pub = self.create_publisher(PoseStamped, "/replica/desired_pose", STATUS_QOS)
        self._tcp_pose_pub = self.create_publisher(PoseStamped, "/replica/tcp_pose", STATUS_QOS)
        self._feedback_pub = self.create_publisher(WrenchStamped, "/replica/feedback_wrench", STATUS_QOS)
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", DIAGNOSTICS_QOS)
        self.create_subscription(JointState, "/joint_states", self._on_joint_state_bytes, NEWEST_STATE_QOS, raw=True)
        self.create_subscription(WrenchStamped, "/ft_sensor/wrench", self._on_wrench, NEWEST_STATE_QOS)
        self.create_subscription(TeleoperationCommand, "/replica/teleop_command", self._on_teleop_command,
                                 TELEOP_QOS)
        self.create_subscription(PoseStamped, "/planner/desired_pose", self._on_planner_pose, TELEOP_QOS)
        self.create_subscription(AccelStamped, "/planner/desired_accel", self._on_planner_accel, TELEOP_QOS)
        p = self._loop.parameters
        self._diagnostics_timer = self.create_timer(1.0 / p["diagnostics_rate"], self._publish_diagnostics)
        # The joint-state watchdog runs on the steady clock: with a real driver, silence is wall time.
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        if self._driver.ramp is not None:
            self.create_timer(0.01, self._check_joint_states, clock=self._steady)
        self.get_logger().info(f"driver: {self._driver.describe()}")
        self.get_logger().info(f"replica ready: controller {p['controller']}, control_rate {p['control_rate']:g} Hz, "
                               f"master_timeout {p['master_timeout']:g} s; waiting for /joint_states")

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        changes = {parameter.name: parameter.value for parameter in parameters}
        old_rate = self._loop.parameters["diagnostics_rate"]
        try:
            p = self._loop.configure(changes)
        except FicInputError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        if p["diagnostics_rate"] != old_rate:
            self._diagnostics_timer.cancel()
            self._diagnostics_timer = self.create_timer(1.0 / p["diagnostics_rate"], self._publish_diagnostics)
        self.get_logger().info(f"parameters changed: {', '.join(f'{k}={v}' for k, v in changes.items())}")
        return SetParametersResult(successful=True)

    # --- inputs ----------------------------------------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _refuse(self, topic: str, exc: Exception, consequence: str = "keeping the last good value") -> None:
        """One error line per topic and LOG_THROTTLE_S (rclpy's throttle is per call site: one refused input
        must not silence another's line)."""
        now = time_module.monotonic()
        last = self._refusal_logged.get(topic)
        if last is None or now - last >= LOG_THROTTLE_S:
            self._refusal_logged[topic] = now
            self.get_logger().error(f"refusing {topic}: {exc}; {consequence}")

    def _on_teleop_command(self, message: TeleoperationCommand) -> None:
        # None: refused (said there) or in the safe hold
        offset = self._input_guard.teleop_offset(message, resuming=self._loop.desired.master_stale)
        if offset is None:
            self._loop.counts["rejected_teleop_commands"] += 1
            return
        try:
            notice = self._loop.add_teleoperation(nanoseconds(message.header.stamp), tuple(offset.tolist()),
                                                  self._now())
        except FicInputError as exc:
            return self._refuse("/replica/teleop_command", exc)
        if notice:
            self.get_logger().warning(notice)

    def _on_planner_pose(self, message: PoseStamped) -> None:
        try:
            self._loop.add_planner_pose(nanoseconds(message.header.stamp), xyz(message.pose.position),
                                        xyzw(message.pose.orientation), self._now())
        except FicInputError as exc:
            self._refuse("/planner/desired_pose", exc)

    def _on_planner_accel(self, message: AccelStamped) -> None:
        try:
            self._loop.add_planner_acceleration(xyz(message.accel.linear), self._now())
        except FicInputError as exc:
            self._refuse("/planner/desired_accel", exc)

    def _on_wrench(self, message: WrenchStamped) -> None:
        command = self._loop.last_command
        try:  # the declared base frame, sign and reference point (fic_core.wrench_frame)
            force, torque = self._driver.wrench_frame.at_tcp(
                message.header.frame_id, xyz(message.wrench.force), xyz(message.wrench.torque),
                None if command is None else command.tcp_rotation)
        except FicInputError as exc:
            # F_R goes to zero rather than stay at an old value: the operator feels nothing instead of a wrong push.
            self._loop.counts["rejected_wrenches"] += 1
            self._refuse("/ft_sensor/wrench", exc, "F_R = 0 until a valid one")
            force = torque = np.zeros(3)
        else:
            self._loop.counts["wrenches"] += 1
        wrench = message.wrench
        wrench.force.x, wrench.force.y, wrench.force.z = (float(v) for v in force)
        wrench.torque.x, wrench.torque.y, wrench.torque.z = (float(v) for v in torque)
        message.header.frame_id = self._driver.base_frame
        self._wrench = message  # F_R: the F/T reading, with the sensor's stamp

    # --- the control step ------------------------------------------------------------------------------------
    def _on_joint_state_bytes(self, data: bytes) -> None:
        """The joint state as CDR bytes: its header stamp (right after the 4-byte encapsulation) tells whether it
        is needed; the others are counted and dropped unconverted (a JointState costs tens of microseconds)."""
        raw_stamp = header_stamp(data)  # None: not plain CDR, the stamp is read from the message instead
        message = deserialize_message(data, JointState) if raw_stamp is None else None
        stamp_s = stamp_seconds(raw_stamp) if raw_stamp is not None else seconds(message.header.stamp)
        usable = self._input_guard.joint_state_usable(stamp_s)  # not back in time, not from the future
        if not usable or self._input_guard.held:  # held: no torque at all, the robot's own watchdog holds the arm
            self._loop.counts["rejected_joint_states"] += 1
            return
        if self._loop.skips(stamp_s):
            return self._loop.skip()
        if message is None:
            message = deserialize_message(data, JointState)
        try:
            q, qd = self._joints.pick(message.name, message.position, message.velocity)
        except FicInputError as exc:
            self._refuse("/joint_states", exc)
            return self._publish_torque(self._loop.refuse_joint_state())
        stamp = message.header.stamp
        if self._driver.ramp is not None and self._driver.ramp.fresh(self._steady.now().nanoseconds * 1e-9):
            self.get_logger().warning("joint states are back: the law takes over from the ramp (slewed at the "
                                      "torque-rate limit)")
        step = self._loop.joint_state(nanoseconds(stamp) * 1e-9, self._now(), q, qd)
        for level, text in step.notices:  # one call site per severity (rclpy's logger requires it)
            if level == "error":
                self.get_logger().error(text, throttle_duration_sec=LOG_THROTTLE_S)
            elif level == "warning":
                self.get_logger().warning(text)
            else:
                self.get_logger().info(text)
        self._publish_torque(step.torque)
        command = self._loop.last_command
        if step.poses_due and command is not None:
            self._publish_pose(self._desired_pose_pub, stamp, command.desired_position, command.desired_rotation)
            self._publish_pose(self._tcp_pose_pub, stamp, command.tcp_position, command.tcp_rotation)
            if self._wrench is not None:
                self._feedback_pub.publish(self._wrench)
        if step.status_due:
            self._publish_status(command, stamp)

    # --- outputs ---------------------------------------------------------------------------------------------
    def _publish_torque(self, torque: np.ndarray | None) -> None:
        """Send the loop's tau as the driver expects it: tau, or tau - G(q) when the robot adds G(q) itself
        (G at the state of the last control tick)."""
        if self._driver.ramp is not None and self._driver.ramp.stale:
            return  # the ramp owns the command until a valid joint state comes (a refused one repeats nothing)
        if torque is not None:
            command = self._driver.command(torque, self._loop.robot)
            self._published = command
            self._command_pub.publish(Float64MultiArray(data=command.tolist()))

    def _check_joint_states(self) -> None:
        """No valid joint state for joint_state_timeout: ramp the command to the gravity-only hold (a driver's
        forward controller would hold the last torque forever; fic_core.stale_input_ramp)."""
        ramp = self._driver.ramp
        now = self._steady.now().nanoseconds * 1e-9
        if ramp.check(now, self._published):
            self._loop.counts["ramp_downs"] = self._loop.counts.get("ramp_downs", 0) + 1
            self.get_logger().error(
                f"no valid joint state for more than joint_state_timeout = {ramp.timeout:g} s: ramping the torque "
                f"command to the gravity-only hold over {ramp.ramp_time:g} s")
        rest = self._driver.rest_command()
        if ramp.stale and rest is not None:
            command = ramp.command(now, rest)  # at most 2 x 87 N m / ramp_time: inside the torque-rate limit
            self._published = command
            self._command_pub.publish(Float64MultiArray(data=command.tolist()))

    def _publish_status(self, command, stamp: Time) -> None:
        # FicState is stamped when it is published (the node clock); the pipeline latency (master sample -> the
        # command that first used it) is master_age, taken at that first use. LimitStatus and the poses carry the
        # joint state's stamp.
        desired = self._loop.desired
        state = FicState(controller=command.controller_name, phase=[int(x) for x in command.phase],
                         error=np.concatenate((command.tracking_error, command.rotation_error)).tolist(),
                         latched_max_error=command.latched_max_error.tolist(), force=command.wrench.tolist(),
                         stored_energy=command.stored_energy.tolist(), total_energy=float(command.total_energy),
                         master_age=desired.master_first_use_age, master_stale=desired.master_stale)
        state.header.stamp = self.get_clock().now().to_msg()
        state.header.frame_id = self._driver.base_frame
        used = desired.master_stamp_used_ns
        state.master_stamp = time_message(used)
        passivity = self._loop.passivity
        state.port_work, state.passivity_margin = passivity.port_work.tolist(), passivity.margin.tolist()
        state.passivity_margin_min, state.passivity_violation_ticks = passivity.min_margin, passivity.violation_ticks
        self._fic_state_pub.publish(state)
        shaping, violations = self._loop.take_limit_flags()
        controller = self._loop.controller
        status = LimitStatus(shaping=shaping, violations=violations, torque_change=float(command.torque_change),
                             torque_ratio=command.torque_ratio.tolist(),
                             torque_rate_ratio=command.torque_rate_ratio.tolist(),
                             joint_velocity_ratio=command.joint_velocity_ratio.tolist(),
                             joint_position_margin=command.joint_position_margin.tolist(),
                             tcp_speed=float(command.tcp_speed), ticks=controller.ticks,
                             shaped_ticks=controller.shaped_ticks, violation_ticks=controller.violation_ticks)
        status.header.stamp = stamp
        status.header.frame_id = self._driver.base_frame
        self._limit_status_pub.publish(status)

    def _publish_pose(self, publisher, stamp: Time, position: np.ndarray, rotation: np.ndarray) -> None:
        pose = PoseStamped()
        pose.header.stamp = stamp
        pose.header.frame_id = self._driver.base_frame
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = position.tolist()
        o = pose.pose.orientation
        o.x, o.y, o.z, o.w = pin.Quaternion(rotation).coeffs().tolist()
        publisher.publish(pose)

    def statistics(self) -> dict[str, str]:
        return {**self._input_guard.diagnostic_values(), **self._loop.statistics()}

    def _publish_diagnostics(self) -> None:
        status = DiagnosticStatus(name="replica", hardware_id="fic_teleop_replica")
        stale = self._loop.desired.master_stale
        limits_broken, passivity_broken = self._loop.controller.violation_ticks, self._loop.passivity.violation_ticks
        if self._input_guard.held:
            status.level = DiagnosticStatus.ERROR
            status.message = f"safe hold: {self._input_guard.streams.reason}"
        elif stale or limits_broken or passivity_broken:
            status.level = DiagnosticStatus.WARN
            status.message = "master stale: holding x_d'" if stale else ("limit violations seen" if limits_broken else
                                                                          "passivity violated: the controller gave "
                                                                          "out energy it did not take in")
        else:
            status.level = DiagnosticStatus.OK
            status.message = "running" if self._loop.desired.started else "waiting for /joint_states"
        status.values = [KeyValue(key=key, value=value) for key, value in self.statistics().items()]
        array = DiagnosticArray(status=[status])
        array.header.stamp = self.get_clock().now().to_msg()
        self._diagnostics_pub.publish(array)


def main(args: list[str] | None = None) -> None:
    run_node(ReplicaNode, NODE_NAME, args, stopped=lambda node: rclpy.logging.get_logger(NODE_NAME).info(
        f"replica stopped: {node.statistics()}"))


if __name__ == "__main__":
    main()
