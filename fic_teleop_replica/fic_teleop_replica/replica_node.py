"""ROS 2 shell around fic_core's replica station (paper Eq. 7 + postural optimisation; fic_core.replica_station).

Data path (docs/CONVENTIONS.md):
    /joint_states (1 kHz)  ---------------------------------\\
    /replica/teleop_command (x_d', delayed by the channel) --+--> fic_core.ReplicaStation: the input guard, the
    /planner/desired_pose, /planner/desired_accel (x_d'') ---/    channel's port, ReplicaLoop, the driver's command
    /effort_controller/commands (7 torques) <-------------------------------------------------/
    /ft_sensor/wrench (F_R) --> /replica/feedback_wrench (pose_rate, to the channel and the master)

Wiring only: the parameters are one table (schema.py, values in config/replica.yaml), messages become the station's
calls, what the station returns is published (messages.py) and its notices logged. Every rule (the control grid,
the holds of x_d' and x_d'', the loop's health, the slew, the input authority and the one-writer rule, the driver's
conventions) is fic_core's; input_guard.py looks the writers up in the graph. Messages with NaN/Inf are refused
(one line per topic and 2 s) and the last good value is kept.

The channel's replica port (fic_core.channel_ports.ReplicaChannelPort, in the station): every delivered x_d' is
booked against the F_R last sent back (and with channel_passivity_control, TDPA, corrected) before the loop takes
it; its E_in goes out with F_R on /replica/port_energy, the master port's E_in comes in on
/replica/master_port_energy. With exchanged_energy_observer the FIC's own port is booked by the exchanged-energy
observer (fic_core.exchanged_energy_ports) at every control tick, on /diagnostics as "replica: exchanged energy".
"""
from __future__ import annotations

import functools
import threading

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import AccelStamped, PoseStamped, Vector3Stamped, WrenchStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, MultiArrayLayout

from fic_core import command_stamp
from fic_core.errors import FicInputError
from fic_core.replica_station import ReplicaParameters, ReplicaStation
from fic_teleop_msgs.msg import FicState, LimitStatus, TeleoperationCommand
from fic_teleop_replica import messages
from fic_teleop_replica.input_guard import InputGuard
from fic_teleop_replica.schema import SCHEMA
from fic_teleop_runtime import qos
from fic_teleop_runtime.cdr_header import header_stamp, stamp_seconds
from fic_teleop_runtime.geometry import set_xyz, xyz, xyzw
from fic_teleop_runtime.in_process_link import LINK
from fic_teleop_runtime.node_main import NodeEntry, run_entry
from fic_teleop_runtime.notices import RefusalLog, log_notices
from fic_teleop_runtime.parameters import declare
from fic_teleop_runtime.passivity_status import channel_port_status, exchanged_energy_status
from fic_teleop_runtime.record_batch import BatchedPublisher
from fic_teleop_runtime.stamps import nanoseconds, seconds

NODE_NAME = "replica"


def _locked(method):
    """``method`` under the node's lock: with the robot in this process the control step runs in its physics
    thread, every other callback in the executor's."""
    @functools.wraps(method)
    def locked(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)
    return locked


class ReplicaNode(Node):
    def __init__(self, **node_options) -> None:  # node_options: rclpy Node keywords (node_group.py)
        super().__init__(NODE_NAME, **node_options)
        values = declare(self, SCHEMA)  # every row with its config/replica.yaml value; unknown keys refused
        self._station = ReplicaStation(ReplicaParameters.from_values(values))   # FicInputError if bad
        self._robot_in_process = self._station.driver.in_process
        # With the robot in this process its physics thread runs the control step (in_process_link.py), while the
        # executor thread takes the set-points: one lock keeps the station's state whole between them.
        self._lock = threading.RLock()
        self._loop = self._station.loop
        self._driver = self._station.driver
        self._wrench: WrenchStamped | None = None  # F_R as last received
        self._refusals = RefusalLog(self.get_logger())
        self._input_guard = InputGuard(self, self._station, on_hold=lambda: self._publish_diagnostics(),
                                       lock=self._lock)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        # The robot-side QoS (fic_teleop_runtime.qos): the command and the status streams RELIABLE with a deep
        # writer history for the recorder; joint states and F_R the newest only (no backlog of old states for the
        # law); set-points depth 1 (only the newest is used).
        publisher = self.create_publisher
        # The torque command reaches the recorder in batches (record_batch.py); the driver reads the topic itself.
        self._command_pub = BatchedPublisher(self, Float64MultiArray, "/effort_controller/commands", qos.ROBOT_STREAM,
                                             values["record_batch_period"])
        self._fic_state_pub = publisher(FicState, "/replica/fic_state", qos.STREAM_WRITER)
        self._limit_status_pub = publisher(LimitStatus, "/replica/limit_status", qos.STREAM_WRITER)
        self._desired_pose_pub = publisher(PoseStamped, "/replica/desired_pose", qos.STREAM_WRITER)
        self._tcp_pose_pub = publisher(PoseStamped, "/replica/tcp_pose", qos.STREAM_WRITER)
        self._feedback_pub = publisher(WrenchStamped, "/replica/feedback_wrench", qos.STREAM_WRITER)
        self._diagnostics_pub = publisher(DiagnosticArray, "/diagnostics", qos.DIAGNOSTICS)
        self._port_energy_pub = publisher(Vector3Stamped, "/replica/port_energy", qos.STREAM_WRITER)
        guard = self._input_guard   # the guarded streams: a second writer matched is the safe hold at once
        self.create_subscription(Vector3Stamped, "/replica/master_port_energy", self._on_master_port_energy,
                                 qos.STREAM, event_callbacks=guard.stream_events("/replica/master_port_energy"))
        if not self._robot_in_process:  # else the robot's physics thread calls the control step (below)
            self.create_subscription(JointState, "/joint_states", self._on_joint_state_bytes, qos.NEWEST, raw=True,
                                     event_callbacks=guard.stream_events("/joint_states"))
            self.create_subscription(WrenchStamped, "/ft_sensor/wrench", self._on_wrench, qos.NEWEST,
                                     event_callbacks=guard.stream_events("/ft_sensor/wrench"))
        self.create_subscription(TeleoperationCommand, "/replica/teleop_command", self._on_teleop_command,
                                 qos.SET_POINT)
        self.create_subscription(PoseStamped, "/planner/desired_pose", self._on_planner_pose, qos.SET_POINT,
                                 event_callbacks=guard.stream_events("/planner/desired_pose"))
        self.create_subscription(AccelStamped, "/planner/desired_accel", self._on_planner_accel, qos.SET_POINT,
                                 event_callbacks=guard.stream_events("/planner/desired_accel"))
        p = self._loop.parameters
        self._diagnostics_timer = self.create_timer(1.0 / p.diagnostics_rate, self._publish_diagnostics)
        # The joint-state watchdog runs on the steady clock: with a real driver, silence is wall time.
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        if self._driver.ramp is not None:
            self.create_timer(0.01, self._check_joint_states, clock=self._steady)
        self.get_logger().info(f"driver: {self._driver.describe()}")
        self._detached = False
        if self._robot_in_process:  # last: the robot's physics thread may call in at once (in_process_link.py)
            LINK.wrench_reader = self._on_wrench
            LINK.joint_state_reader = self._on_joint_state
        source = "the robot in this process" if self._robot_in_process else "/joint_states"
        self.get_logger().info(f"replica ready: controller {p.controller}, control_rate {p.control_rate:g} Hz, "
                               f"master_timeout {p.master_timeout:g} s; waiting for {source}")

    @_locked
    def _on_set_parameters(self, parameters) -> SetParametersResult:
        changes = {parameter.name: parameter.value for parameter in parameters}
        old_rate = self._loop.parameters.diagnostics_rate
        try:
            p = self._station.configure(changes)
        except FicInputError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        if p.diagnostics_rate != old_rate:
            self._diagnostics_timer.cancel()
            self._diagnostics_timer = self.create_timer(1.0 / p.diagnostics_rate, self._publish_diagnostics)
        self.get_logger().info(f"parameters changed: {', '.join(f'{k}={v}' for k, v in changes.items())}")
        return SetParametersResult(successful=True)

    # --- inputs ----------------------------------------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _steady_now(self) -> float:
        return self._steady.now().nanoseconds * 1e-9

    @_locked
    def _on_teleop_command(self, message: TeleoperationCommand) -> None:
        station = self._station
        writers = 1 if station.held else self._input_guard.teleop_writers()
        try:
            notices = station.teleoperation_command(
                nanoseconds(message.header.stamp), self._now(), mode=int(message.mode),
                haptic_gain=message.haptic_gain, workspace_scale=message.workspace_scale,
                velocity_gain=message.velocity_gain, handle_position=xyz(message.handle_position),
                desired_offset=xyz(message.desired_offset), writers=writers)
        except FicInputError as exc:
            return self._refusals.refuse("/replica/teleop_command", exc)
        log_notices(self.get_logger(), notices)

    @_locked
    def _on_master_port_energy(self, message: Vector3Stamped) -> None:
        try:
            self._station.master_port_energy(message.vector.x)  # x: the master port's E_in
        except FicInputError as exc:
            self._refusals.refuse("/replica/master_port_energy", exc)

    @_locked
    def _on_planner_pose(self, message: PoseStamped) -> None:
        try:
            notices = self._station.planner_pose(nanoseconds(message.header.stamp), xyz(message.pose.position),
                                                 xyzw(message.pose.orientation), self._now())
        except FicInputError as exc:
            return self._refusals.refuse("/planner/desired_pose", exc)
        log_notices(self.get_logger(), notices)

    @_locked
    def _on_planner_accel(self, message: AccelStamped) -> None:
        try:
            self._station.planner_acceleration(xyz(message.accel.linear), self._now())
        except FicInputError as exc:
            self._refusals.refuse("/planner/desired_accel", exc)

    @_locked
    def _on_wrench(self, message: WrenchStamped) -> None:
        force, torque, error = self._station.wrench(message.header.frame_id, xyz(message.wrench.force),
                                                    xyz(message.wrench.torque))
        if error is not None:
            self._refusals.refuse("/ft_sensor/wrench", error, "F_R = 0 until a valid one")
        set_xyz(message.wrench.force, force)
        set_xyz(message.wrench.torque, torque)
        message.header.frame_id = self._driver.base_frame
        self._wrench = message  # F_R: the F/T reading, with the sensor's stamp

    # --- the control step ------------------------------------------------------------------------------------
    @_locked
    def _on_joint_state_bytes(self, data: bytes) -> None:
        """The joint state as CDR bytes: its header stamp tells whether it is needed; the others are counted and
        dropped unconverted (a JointState costs tens of microseconds)."""
        raw_stamp = header_stamp(data)  # None: not plain CDR, the stamp is read from the message instead
        message = deserialize_message(data, JointState) if raw_stamp is None else None
        stamp_s = stamp_seconds(raw_stamp) if raw_stamp is not None else seconds(message.header.stamp)
        if self._admits(stamp_s):
            self._control_step(message if message is not None else deserialize_message(data, JointState))

    @_locked
    def _on_joint_state(self, message: JointState) -> None:
        """The joint state from the robot in this process (its physics thread; in_process_link.py)."""
        if not self._detached and self._admits(seconds(message.header.stamp)):
            self._control_step(message)

    @_locked
    def detach(self) -> None:
        """No more control steps from the robot's thread (the node is stopping: its publishers go next)."""
        self._detached = True
        if LINK.joint_state_reader == self._on_joint_state:
            LINK.joint_state_reader = LINK.wrench_reader = None

    def _admits(self, stamp_s: float) -> bool:
        """Whether a joint state stamped ``stamp_s`` gets a control step: forward, not from the future, not held,
        on the control grid."""
        station = self._station
        usable, reason = station.admits_joint_state(stamp_s, self._now())  # forward, not from the future
        if reason:
            self._input_guard.hold(reason)
        # held: no torque at all, the robot's own watchdog holds the arm
        return usable and not station.skips(stamp_s)

    def _control_step(self, message: JointState) -> None:
        station = self._station
        stamp = message.header.stamp
        stamp_ns = nanoseconds(stamp)
        tick, error = station.named_joint_state(stamp_ns * 1e-9, self._now(), message.name, message.position,
                                                message.velocity, stamp_ns, self._steady_now())
        if error is not None:
            self._refusals.refuse("/joint_states", error)
            return self._publish_command(tick.command, tick.state_stamp_ns)
        step = tick.step
        log_notices(self.get_logger(), step.notices)
        self._publish_command(tick.command, tick.state_stamp_ns)
        if tick.hold_began:  # the loop's own hold began: on /diagnostics (and in the bag) at once
            self._publish_diagnostics()
        command, frame = self._loop.last_command, self._driver.base_frame
        if step.poses_due and command is not None:
            self._desired_pose_pub.publish(messages.pose(stamp, frame, command.desired_position,
                                                         command.desired_rotation))
            self._tcp_pose_pub.publish(messages.pose(stamp, frame, command.tcp_position, command.tcp_rotation))
            if tick.feedback is not None:  # F_R of self._wrench, its E_in booked by the station
                self._feedback_pub.publish(self._wrench)
                observer = station.channel_port.observer
                energy = Vector3Stamped(header=self._wrench.header)
                energy.vector.x, energy.vector.y, energy.vector.z = (observer.input_energy, observer.output_energy,
                                                                     observer.energy)
                self._port_energy_pub.publish(energy)
        if step.status_due:
            self._fic_state_pub.publish(messages.fic_state(command, self._loop, self.get_clock().now().to_msg(),
                                                           frame))
            self._limit_status_pub.publish(messages.limit_status(command, self._loop, stamp, frame))

    # --- outputs ---------------------------------------------------------------------------------------------
    def _publish_command(self, command: np.ndarray | None, state_stamp_ns: int | None) -> None:
        """Send the driver's command (driver semantics: tau, or tau - G(q)), naming the joint state it was computed
        on (fic_core.command_stamp: the robot refuses a torque on too old a state)."""
        if command is not None:
            layout = MultiArrayLayout() if state_stamp_ns is None else MultiArrayLayout(dim=[MultiArrayDimension(
                label=command_stamp.label(state_stamp_ns), size=command.size, stride=command.size)])
            self._send_command(Float64MultiArray(layout=layout, data=command.tolist()))

    def _send_command(self, message: Float64MultiArray) -> None:
        """To the robot in this process first (in_process_link.py), then on DDS (the robot's input when it runs
        elsewhere, and the record of every command either way)."""
        if self._robot_in_process and LINK.command_reader is not None:
            LINK.command_reader(message)
        self._command_pub.publish(message)

    @_locked
    def _check_joint_states(self) -> None:
        """No valid joint state for joint_state_timeout: the driver's ramp to the gravity-only hold."""
        command, notices = self._station.ramp(self._steady_now())
        log_notices(self.get_logger(), notices)
        if command is not None:
            self._send_command(Float64MultiArray(data=command.tolist()))

    def statistics(self) -> dict[str, str]:
        return self._station.statistics()

    @_locked
    def _publish_diagnostics(self) -> None:
        station = self._station
        array = DiagnosticArray(status=[messages.diagnostic_status(self._loop, station.hold_reason, self.statistics()),
                                        channel_port_status("replica", "forward", station.channel_port.diagnostics()),
                                        messages.loop_health_status(self._loop.health)])
        if station.exchanged is not None:
            array.status.append(exchanged_energy_status("replica", station.exchanged.observer, "(N s/m, N m s/rad)"))
        array.header.stamp = self.get_clock().now().to_msg()
        self._diagnostics_pub.publish(array)


def main(args: list[str] | None = None) -> None:
    run_entry(ENTRY, args)


def _stopped(node: ReplicaNode) -> None:
    """The final counters once more on /diagnostics (a recorder behind a starved graph still takes them: it stops
    last) and in the log, which the launcher reads when the bag holds none (launch_supervision.py)."""
    node.detach()
    try:
        node._publish_diagnostics()
    except Exception:  # noqa: BLE001 - the context already gone (an external shutdown): the log line remains
        pass
    rclpy.logging.get_logger(NODE_NAME).info(f"{STOPPED_LINE}{node.statistics()}")


#: The replica's last log line begins so, followed by its statistics as a dict (launch_supervision reads it).
STOPPED_LINE = "replica stopped: "
# The EventsExecutor under simulated time too (lockstep): the replica is driven by its joint states, not by timers
# on the simulated clock (its one timer is the 1 Hz /diagnostics, which lands on whole simulated seconds all the same),
# and the wait-set executor cost it 2.3 ms of CPU a lockstep step against 0.9 ms (docs/RESULTS.md, "Lockstep").
ENTRY = NodeEntry(ReplicaNode, NODE_NAME, stopped=_stopped, follow_sim_time=False)


if __name__ == "__main__":
    main()
