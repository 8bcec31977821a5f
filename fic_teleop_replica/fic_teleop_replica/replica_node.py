"""ROS 2 shell around fic_core's replica loop (paper Eq. 7 + postural optimisation; fic_core.replica_loop).

Data path (docs/CONVENTIONS.md):
    /joint_states (1 kHz)  ---------------------------------\\
    /replica/teleop_command (x_d', delayed by the channel) --+--> fic_core.ReplicaLoop: x_d = x_d' + x_d'',
    /planner/desired_pose, /planner/desired_accel (x_d'') ---/    ReplicaController, torque slew
    /effort_controller/commands (7 torques) <-------------------------------------------------/
    /ft_sensor/wrench (F_R) --> /replica/feedback_wrench (pose_rate, to the channel and the master)

Wiring only: the parameters are one table (schema.py, values in config/replica.yaml), messages become the loop's
calls, what the loop returns is published (messages.py) and its notices logged. Every rule (the control grid, the
holds of x_d' and x_d'', the watchdog and its give-back, the slew at the torque-rate limit) is fic_core's; what an
outside input may ask is input_guard.py's, the driver's conventions driver_interface.py's. Messages with NaN/Inf
are refused (one line per topic and 2 s) and the last good value is kept.

The channel's replica port (fic_core.channel_ports.ReplicaChannelPort): every delivered x_d' is booked against the
F_R last sent back (and with channel_passivity_control, TDPA, corrected) before the loop takes it; its E_in goes
out with F_R on /replica/port_energy, the master port's E_in comes in on /replica/master_port_energy.
With exchanged_energy_observer (the launcher's lockstep runs), the FIC's own port is booked by the exchanged-energy
observer (fic_core.exchanged_energy_ports) at every control tick, on /diagnostics as "replica: exchanged energy".
"""
from __future__ import annotations

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from fic_teleop_msgs.msg import FicState, LimitStatus, TeleoperationCommand
from geometry_msgs.msg import AccelStamped, PoseStamped, Vector3Stamped, WrenchStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, MultiArrayLayout

from fic_core.channel_ports import ReplicaChannelPort
from fic_core import command_stamp
from fic_core.errors import FicInputError
from fic_core.exchanged_energy_ports import ReplicaExchangedEnergy
from fic_core.input_authority import AuthorityBounds, CommandAuthority
from fic_core.replica_loop import ReplicaLoop
from fic_core.replica_parameters import REPLICA_LOOP_PARAMETERS
from fic_core.robot_model import RobotModel
from fic_teleop_replica import messages
from fic_teleop_replica.driver_interface import DriverInterface
from fic_teleop_replica.input_guard import InputGuard
from fic_teleop_replica.schema import SCHEMA
from fic_teleop_runtime import qos
from fic_teleop_runtime.cdr_header import header_stamp, stamp_seconds
from fic_teleop_runtime.geometry import set_xyz, xyz, xyzw
from fic_teleop_runtime.node_main import NodeEntry, run_entry
from fic_teleop_runtime.notices import RefusalLog, log_notices
from fic_teleop_runtime.parameters import declare
from fic_teleop_runtime.passivity_status import channel_port_status, exchanged_energy_status
from fic_teleop_runtime.stamps import nanoseconds, seconds

NODE_NAME = "replica"


class ReplicaNode(Node):
    def __init__(self, **node_options) -> None:  # node_options: rclpy Node keywords (node_group.py)
        super().__init__(NODE_NAME, **node_options)
        values = declare(self, SCHEMA)  # every row with its config/replica.yaml value; unknown keys refused
        # The driver behind the topics: arm, joint names, gravity semantics, wrench frame, ramp-down (docs/HARDWARE.md).
        self._driver = DriverInterface(values)
        robot = RobotModel()
        # What an outside input may ask of the arm (fic_core.input_authority): bounded commands (the loop's
        # authority), one writer per robot stream (the guard's); a breach holds the arm, said at once on /diagnostics.
        authority = CommandAuthority(AuthorityBounds.from_parameters(values))
        self._loop = ReplicaLoop({name: values[name] for name in REPLICA_LOOP_PARAMETERS}, robot,
                                 self._driver.limits(robot), authority)  # FicInputError if bad
        self._wrench: WrenchStamped | None = None  # F_R as last received
        self._channel_port = ReplicaChannelPort(values["channel_passivity_control"], values["channel_energy_window"])
        self._exchanged = ReplicaExchangedEnergy(1.0 / values["control_rate"]) \
            if values["exchanged_energy_observer"] else None
        self._refusals = RefusalLog(self.get_logger())
        self._input_guard = InputGuard(self, values, authority, on_hold=lambda: self._publish_diagnostics())
        self.add_on_set_parameters_callback(self._on_set_parameters)
        # The robot-side QoS (fic_teleop_runtime.qos): the command and the status streams RELIABLE with a deep
        # writer history for the recorder; joint states and F_R the newest only (no backlog of old states for the
        # law); set-points depth 1 (only the newest is used).
        publisher = self.create_publisher
        self._command_pub = publisher(Float64MultiArray, "/effort_controller/commands", qos.ROBOT_STREAM)
        self._fic_state_pub = publisher(FicState, "/replica/fic_state", qos.STREAM_WRITER)
        self._limit_status_pub = publisher(LimitStatus, "/replica/limit_status", qos.STREAM_WRITER)
        self._desired_pose_pub = publisher(PoseStamped, "/replica/desired_pose", qos.STREAM_WRITER)
        self._tcp_pose_pub = publisher(PoseStamped, "/replica/tcp_pose", qos.STREAM_WRITER)
        self._feedback_pub = publisher(WrenchStamped, "/replica/feedback_wrench", qos.STREAM_WRITER)
        self._diagnostics_pub = publisher(DiagnosticArray, "/diagnostics", qos.DIAGNOSTICS)
        self._port_energy_pub = publisher(Vector3Stamped, "/replica/port_energy", qos.STREAM_WRITER)
        self.create_subscription(Vector3Stamped, "/replica/master_port_energy", self._on_master_port_energy,
                                 qos.STREAM)
        self.create_subscription(JointState, "/joint_states", self._on_joint_state_bytes, qos.NEWEST, raw=True,
                                 event_callbacks=self._input_guard.joint_state_events())
        self.create_subscription(WrenchStamped, "/ft_sensor/wrench", self._on_wrench, qos.NEWEST)
        self.create_subscription(TeleoperationCommand, "/replica/teleop_command", self._on_teleop_command,
                                 qos.SET_POINT)
        # The planner's streams: one writer at most, else the safe hold (input_guard.SET_POINT_STREAMS).
        self.create_subscription(PoseStamped, "/planner/desired_pose", self._on_planner_pose, qos.SET_POINT,
                                 event_callbacks=self._input_guard.set_point_events("/planner/desired_pose"))
        self.create_subscription(AccelStamped, "/planner/desired_accel", self._on_planner_accel, qos.SET_POINT,
                                 event_callbacks=self._input_guard.set_point_events("/planner/desired_accel"))
        p = self._loop.parameters
        self._diagnostics_timer = self.create_timer(1.0 / p["diagnostics_rate"], self._publish_diagnostics)
        # The joint-state watchdog runs on the steady clock: with a real driver, silence is wall time.
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._state_stamp_ns: int | None = None   # the joint state the last torque was computed on
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

    def _steady_now(self) -> float:
        return self._steady.now().nanoseconds * 1e-9

    def _on_teleop_command(self, message: TeleoperationCommand) -> None:
        if not self._input_guard.admits_teleop_command():  # the safe hold, or a second writer (said there)
            self._loop.counts["rejected_teleop_commands"] += 1
            return
        try:
            now = self._now()
            offset = self._channel_port.delivery(xyz(message.desired_offset), now)  # the channel's replica port
            verdict, notice = self._loop.teleoperation_command(
                nanoseconds(message.header.stamp), now, mode=int(message.mode),
                haptic_gain=message.haptic_gain, workspace_scale=message.workspace_scale,
                velocity_gain=message.velocity_gain, handle_position=xyz(message.handle_position),
                desired_offset=offset)
        except FicInputError as exc:
            return self._refusals.refuse("/replica/teleop_command", exc)
        self._input_guard.report(verdict)
        if notice:
            self.get_logger().warning(notice)

    def _on_master_port_energy(self, message: Vector3Stamped) -> None:
        try:
            self._channel_port.receive_energy(message.vector.x)  # x: the master port's E_in
        except FicInputError as exc:
            self._refusals.refuse("/replica/master_port_energy", exc)

    def _on_planner_pose(self, message: PoseStamped) -> None:
        if self._input_guard.held:  # the safe hold: no set-point is taken any more
            self._loop.counts["rejected_planner_poses"] += 1
            return
        bounded = self._loop.planner_authority
        before = bounded.clamped + bounded.rate_limited
        try:
            self._loop.add_planner_pose(nanoseconds(message.header.stamp), xyz(message.pose.position),
                                        xyzw(message.pose.orientation), self._now())
        except FicInputError as exc:
            self._refusals.refuse("/planner/desired_pose", exc)
            return
        if bounded.clamped + bounded.rate_limited != before:  # fic_core.input_authority.SetPointAuthority
            self.get_logger().warning(f"/planner/desired_pose: {bounded.last_reason} ({bounded.clamped} outside the "
                                      f"workspace, {bounded.rate_limited} rate-limited so far)",
                                      throttle_duration_sec=2.0)

    def _on_planner_accel(self, message: AccelStamped) -> None:
        if self._input_guard.held:
            self._loop.counts["rejected_planner_poses"] += 1
            return
        try:
            self._loop.add_planner_acceleration(xyz(message.accel.linear), self._now())
        except FicInputError as exc:
            self._refusals.refuse("/planner/desired_accel", exc)

    def _on_wrench(self, message: WrenchStamped) -> None:
        command = self._loop.last_command
        try:  # the declared base frame, sign and reference point (fic_core.wrench_frame)
            force, torque = self._driver.wrench_frame.at_tcp(
                message.header.frame_id, xyz(message.wrench.force), xyz(message.wrench.torque),
                None if command is None else command.tcp_rotation)
        except FicInputError as exc:
            # F_R goes to zero rather than stay at an old value: the operator feels nothing instead of a wrong push.
            self._loop.counts["rejected_wrenches"] += 1
            self._refusals.refuse("/ft_sensor/wrench", exc, "F_R = 0 until a valid one")
            force = torque = np.zeros(3)
        else:
            self._loop.counts["wrenches"] += 1
        set_xyz(message.wrench.force, force)
        set_xyz(message.wrench.torque, torque)
        message.header.frame_id = self._driver.base_frame
        self._wrench = message  # F_R: the F/T reading, with the sensor's stamp

    # --- the control step ------------------------------------------------------------------------------------
    def _on_joint_state_bytes(self, data: bytes) -> None:
        """The joint state as CDR bytes: its header stamp tells whether it is needed; the others are counted and
        dropped unconverted (a JointState costs tens of microseconds)."""
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
            q, qd = self._driver.joint_order.pick(message.name, message.position, message.velocity)
        except FicInputError as exc:
            self._refusals.refuse("/joint_states", exc)
            return self._publish_torque(self._loop.refuse_joint_state(), self._state_stamp_ns)
        stamp = message.header.stamp
        if self._driver.ramp is not None and self._driver.ramp.fresh(self._steady_now()):  # after a ramp-down
            self.get_logger().warning("joint states are back: the law takes over from the ramp (slewed at the "
                                      "torque-rate limit)")
        holds = self._loop.health.holds
        self._state_stamp_ns = nanoseconds(stamp)
        step = self._loop.joint_state(self._state_stamp_ns * 1e-9, self._now(), q, qd)
        step = self._loop.ready(step, self._state_stamp_ns * 1e-9, self._now())  # not grown old inside the tick
        log_notices(self.get_logger(), step.notices)
        self._publish_torque(step.torque, self._state_stamp_ns)
        if self._exchanged is not None and step.command is not None:
            self._exchanged.observe(step.command, self._loop.controller.controller)
        if self._loop.health.holds != holds:  # the loop's own hold began: on /diagnostics (and in the bag) at once
            self._publish_diagnostics()
        command, frame = self._loop.last_command, self._driver.base_frame
        if step.poses_due and command is not None:
            self._desired_pose_pub.publish(messages.pose(stamp, frame, command.desired_position,
                                                         command.desired_rotation))
            self._tcp_pose_pub.publish(messages.pose(stamp, frame, command.tcp_position, command.tcp_rotation))
            if self._wrench is not None:
                self._feedback_pub.publish(self._wrench)
                self._channel_port.sent(xyz(self._wrench.wrench.force))  # E_in travels with F_R
                observer = self._channel_port.observer
                energy = Vector3Stamped(header=self._wrench.header)
                energy.vector.x, energy.vector.y, energy.vector.z = (observer.input_energy, observer.output_energy,
                                                                     observer.energy)
                self._port_energy_pub.publish(energy)
        if step.status_due:
            self._fic_state_pub.publish(messages.fic_state(command, self._loop, self.get_clock().now().to_msg(),
                                                           frame))
            self._limit_status_pub.publish(messages.limit_status(command, self._loop, stamp, frame))

    # --- outputs ---------------------------------------------------------------------------------------------
    def _publish_torque(self, torque: np.ndarray | None, state_stamp_ns: int | None) -> None:
        """Send the loop's tau as the driver expects it (driver_interface: tau, or tau - G(q)), naming the joint state
        it was computed on (fic_core.command_stamp: the robot refuses a torque on too old a state)."""
        command = self._driver.command_to_send(torque, self._loop.robot)
        if command is not None:
            layout = MultiArrayLayout() if state_stamp_ns is None else MultiArrayLayout(dim=[MultiArrayDimension(
                label=command_stamp.label(state_stamp_ns), size=command.size, stride=command.size)])
            self._command_pub.publish(Float64MultiArray(layout=layout, data=command.tolist()))

    def _check_joint_states(self) -> None:
        """No valid joint state for joint_state_timeout: the driver's ramp to the gravity-only hold."""
        command, started = self._driver.ramp_command(self._steady_now())
        if started:
            self._loop.counts["ramp_downs"] = self._loop.counts.get("ramp_downs", 0) + 1
            ramp = self._driver.ramp
            self.get_logger().error(
                f"no valid joint state for more than joint_state_timeout = {ramp.timeout:g} s: ramping the torque "
                f"command to the gravity-only hold over {ramp.ramp_time:g} s")
        if command is not None:
            self._command_pub.publish(Float64MultiArray(data=command.tolist()))

    def statistics(self) -> dict[str, str]:
        return {**self._input_guard.diagnostic_values(), **self._loop.statistics()}

    def _publish_diagnostics(self) -> None:
        hold = self._input_guard.streams.reason if self._input_guard.held else None
        array = DiagnosticArray(status=[messages.diagnostic_status(self._loop, hold, self.statistics()),
                                        channel_port_status("replica", "forward", self._channel_port.diagnostics()),
                                        messages.loop_health_status(self._loop.health)])
        if self._exchanged is not None:
            array.status.append(exchanged_energy_status("replica", self._exchanged.observer, "(N s/m, N m s/rad)"))
        array.header.stamp = self.get_clock().now().to_msg()
        self._diagnostics_pub.publish(array)


def main(args: list[str] | None = None) -> None:
    run_entry(ENTRY, args)


ENTRY = NodeEntry(ReplicaNode, NODE_NAME, stopped=lambda node: rclpy.logging.get_logger(NODE_NAME).info(
    f"replica stopped: {node.statistics()}"))


if __name__ == "__main__":
    main()
