"""Master node: the haptic device's FIC with the replica's force fed back (paper Eq. 3), and the teleoperation
command (offset or velocity mode, paper Sec. II-C) sent to the replica through the channel.

Data path: /haptic/pose (x_M, haptic_base) + /haptic/twist + /master/feedback_wrench (F_R, delayed by the channel)
-> fic_core.MasterStation -> /haptic/wrench_command (f = FIC(-x_M) + K_H*F_R) at ``control_rate``;
x_M -> x_d' -> /master/pose and /master/teleop_command at ``network_rate``. The haptic_base axes are taken as
aligned with panda_link0's (the simulated device is set up that way), so F_R is added without rotation.

Operator inputs: /operator/joy buttons (edges; fic_core.operator_buttons) 0: toggle OFFSET/VELOCITY,
1: K_H + 0.1, 2: K_H - 0.1, 3 held: the clutch; /master/haptic_gain (std_msgs/Float64); or
``scripts/fic param set /master haptic_gain 0.3``. K_H outside [0, 1] is clamped to it with a warning; NaN is
refused. This node is wiring: every rule is in fic_core.

The operator's tools (fic_core.master_station; docs/TOOLS.md, "The operator's tools"), each a parameter settable
live: ``clutch``, ``homing``, ``force_scale`` beside ``workspace_scale`` (the loop-gain bound refuses a change
past k_F s_M K_H = 1 in one line), ``guidance_fixture`` and its ``guidance_*``. A button press and the end of homing
set their parameter too, so ``param get`` tells the truth; their state goes out on /master/operator_tools at
``tools_rate`` and at once when the engagement changes.

The channel's master port (fic_core.channel_ports.MasterChannelPort, the station's): booked at every control tick
before Eq. 3, its E_in sent on /master/port_energy (through channel_forward), the replica port's E_in read from
/master/replica_port_energy; with channel_passivity_control (TDPA) its damper shapes the F_R that Eq. 3 renders.
The handle FIC's port is booked by the exchanged-energy observer (fic_core.exchanged_energy_ports) at every tick
that evaluates Eq. 3, on /diagnostics as "master: exchanged energy". A control tick is the station's one
``update``, which keeps that order.
"""
from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, PoseStamped, TwistStamped, Vector3Stamped, WrenchStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import Joy
from std_msgs.msg import Float64

# Submodule imports: from the repository root a bare `import fic_core` finds the project folder fic_core/ as a
# namespace package first (the editable install resolves submodules only).
from fic_core.errors import FicInputError
from fic_core.master_station import MASTER_PARAMETERS, MasterParameters, MasterStation, clamped_haptic_gain
from fic_teleop_msgs.msg import OperatorTools, TeleoperationCommand
from fic_teleop_runtime import qos
from fic_teleop_runtime.geometry import xyz, xyzw
from fic_teleop_runtime.in_process_link import HANDLE_LINK
from fic_teleop_runtime.node_main import NodeEntry, run_entry
from fic_teleop_runtime.notices import log_notices
from fic_teleop_runtime.parameters import Schema, declare, refuse_unknown_names
from fic_teleop_runtime.passivity_status import channel_port_status, exchanged_energy_status
from fic_teleop_runtime.periodic import PeriodicCallbacks
from fic_teleop_runtime.record_batch import BatchedPublisher

# Device and teleoperation streams RELIABLE (the channel alone loses on purpose), read 20 deep and written with
# the streams' deep writer history; button presses are events: a lost toggle would invert the mode for the rest
# of the run (fic_teleop_runtime.qos).
STREAM_QOS, STREAM_WRITER_QOS = qos.STREAM, qos.STREAM_WRITER
JOY_QOS, DIAGNOSTICS_QOS = qos.EVENTS, qos.DIAGNOSTICS
#: The master's table (fic_core.master_station): the node declares these rows, the station takes their values as
#: one MasterParameters.
SCHEMA = Schema("master.yaml", MASTER_PARAMETERS.values())


class MasterNode(Node):
    def __init__(self, **node_options) -> None:  # node_options: rclpy Node keywords (node_group.py)
        super().__init__("master", **node_options)
        self._periodic = PeriodicCallbacks(self)  # timers that follow the simulated clock (periodic.py)
        values = declare(self, SCHEMA)  # every row with its config/master.yaml value; unknown keys refused
        self._station = MasterStation(MasterParameters.from_values(values))
        self._log(self._station.set_haptic_gain(values["haptic_gain"], "parameter"))
        self._frame_id = values["frame_id"]
        self._control_period, self._last_control_tick = 1.0 / values["control_rate"], None
        # The device reads the topic itself; the recorder its batches (record_batch.py).
        self._wrench_publisher = BatchedPublisher(self, WrenchStamped, "/haptic/wrench_command", STREAM_WRITER_QOS,
                                                  values["record_batch_period"])
        self._pose_publisher = self.create_publisher(PoseStamped, "/master/pose", STREAM_WRITER_QOS)
        self._command_publisher = self.create_publisher(TeleoperationCommand, "/master/teleop_command",
                                                        STREAM_WRITER_QOS)
        self._port_energy_publisher = self.create_publisher(Vector3Stamped, "/master/port_energy", STREAM_WRITER_QOS)
        self._diagnostics_publisher = self.create_publisher(DiagnosticArray, "/diagnostics", DIAGNOSTICS_QOS)
        self._tools_publisher = self.create_publisher(OperatorTools, "/master/operator_tools", STREAM_WRITER_QOS)
        self._device_in_process = values["device_in_process"]
        if self._device_in_process:   # the device of this process hands its handle over (in_process_link.py)
            HANDLE_LINK.pose_reader, HANDLE_LINK.twist_reader = self._on_pose, self._on_twist
        else:
            self.create_subscription(PoseStamped, "/haptic/pose", self._on_pose, STREAM_QOS)
            self.create_subscription(TwistStamped, "/haptic/twist", self._on_twist, STREAM_QOS)
        self.create_subscription(WrenchStamped, "/master/feedback_wrench", self._on_feedback, STREAM_QOS)
        self.create_subscription(Vector3Stamped, "/master/replica_port_energy", self._on_replica_port_energy,
                                 STREAM_QOS)
        self.create_subscription(Joy, "/operator/joy", self._on_joy, JOY_QOS)
        self.create_subscription(Float64, "/master/haptic_gain", self._on_haptic_gain, STREAM_QOS)
        self._refuse_unknown_names = refuse_unknown_names(self, SCHEMA)
        self.add_pre_set_parameters_callback(self._clamp_haptic_gain)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        if values["haptic_gain"] != self._station.law.haptic_gain:  # clamped at start: make `param get` show it
            self._sync_haptic_gain_parameter()
        self._periodic.create(1.0 / values["control_rate"], self._control_tick)
        self._periodic.create(1.0 / values["network_rate"], self._network_tick)
        self._periodic.create(1.0 / values["diagnostics_rate"], self._publish_diagnostics)
        self._periodic.create(1.0 / values["tools_rate"], self._publish_tools)
        self.get_logger().info(
            f"master up: K_H = {self._station.law.haptic_gain:.2f}, mode {self._station.integrator.mode.name}, "
            f"{self._station.engagement.name.lower()}, control {values['control_rate']:.0f} Hz, network "
            f"{values['network_rate']:.0f} Hz")

    def _log(self, notices) -> None:
        log_notices(self.get_logger(), notices, throttle_s=1.0)  # repeated warnings at most once a second

    # -- parameters -----------------------------------------------------------------------------------------
    def _clamp_haptic_gain(self, parameters: list[Parameter]) -> list[Parameter]:
        """Pre-set: a name the node does not declare refused in one line; K_H outside [0, 1] becomes the nearest
        bound (logged); NaN passes on to be refused."""
        result = []
        for parameter in self._refuse_unknown_names(parameters):
            if parameter.name == "haptic_gain" and parameter.type_ == Parameter.Type.DOUBLE:
                clamped = clamped_haptic_gain(parameter.value)
                if clamped != parameter.value and clamped == clamped:
                    self.get_logger().warning(f"haptic_gain {parameter.value} is outside [0, 1]: clamped to {clamped}")
                    parameter = Parameter("haptic_gain", Parameter.Type.DOUBLE, clamped)
            result.append(parameter)
        return result

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        engagement = self._station.engagement
        try:
            self._log(self._station.configure({p.name: p.value for p in parameters}))
        except FicInputError as error:
            self.get_logger().error(f"refused: {error}")
            return SetParametersResult(successful=False, reason=str(error))
        if self._station.engagement != engagement:
            self._publish_tools()
        return SetParametersResult(successful=True)

    def _sync_haptic_gain_parameter(self) -> None:
        self.set_parameters([Parameter("haptic_gain", Parameter.Type.DOUBLE, self._station.law.haptic_gain)])

    def _sync_parameters(self, names) -> None:
        """Make ``param get`` show what a button or the station itself changed (the on-set callback then finds
        the station already there)."""
        self.set_parameters([Parameter(name, value=getattr(self._station.parameters, name)) for name in names])

    # -- inputs ---------------------------------------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_pose(self, message: PoseStamped) -> None:
        try:
            self._station.add_pose(xyz(message.pose.position), xyzw(message.pose.orientation), self._now())
        except FicInputError:
            self.get_logger().error("refused /haptic/pose with non-finite values; holding the last good pose",
                                    throttle_duration_sec=1.0)

    def _on_twist(self, message: TwistStamped) -> None:
        try:
            self._station.add_twist(xyz(message.twist.linear), self._now())
        except FicInputError:
            self.get_logger().error("refused /haptic/twist with non-finite values", throttle_duration_sec=1.0)

    def _on_feedback(self, message: WrenchStamped) -> None:
        try:
            self._log(self._station.add_feedback(xyz(message.wrench.force), self._now()))
        except FicInputError:
            self.get_logger().error("refused /master/feedback_wrench with non-finite values",
                                    throttle_duration_sec=1.0)

    def _on_replica_port_energy(self, message: Vector3Stamped) -> None:
        try:
            self._station.replica_port_energy(message.vector.x)  # x: the replica port's E_in
        except FicInputError as error:
            self.get_logger().error(f"refused /master/replica_port_energy: {error}", throttle_duration_sec=1.0)

    def _on_joy(self, message: Joy) -> None:
        engagement = self._station.engagement
        notices, changed = self._station.press(message.buttons)
        self._log(notices)
        self._sync_parameters(changed)
        if self._station.engagement != engagement:
            self._publish_tools()

    def _on_haptic_gain(self, message: Float64) -> None:
        try:
            self._log(self._station.set_haptic_gain(message.data, "/master/haptic_gain"))
        except FicInputError as error:
            self.get_logger().error(f"refused /master/haptic_gain: {error}", throttle_duration_sec=1.0)
            return
        self._sync_haptic_gain_parameter()

    # -- outputs --------------------------------------------------------------------------------------------
    def _control_tick(self) -> None:
        now = self._now()
        dt = self._control_period if self._last_control_tick is None else max(now - self._last_control_tick, 0.0)
        self._last_control_tick = now
        engagement = self._station.engagement
        force, notices = self._station.update(now, dt)  # the channel's port, Eq. 3, the exchanged energy
        if self._station.engagement != engagement:  # homed: engaged (or still clutched)
            self._sync_parameters(("homing",))
            self._publish_tools()
        self._log(notices)
        if force is None:
            return  # no handle yet: nothing to render
        message = WrenchStamped()
        message.header.stamp = self.get_clock().now().to_msg()
        message.header.frame_id = self._frame_id
        message.wrench.force.x, message.wrench.force.y, message.wrench.force.z = (float(f) for f in force)
        if self._device_in_process and HANDLE_LINK.force_reader is not None:
            HANDLE_LINK.force_reader(message)   # the device of this process (in_process_link.py), then DDS
        self._wrench_publisher.publish(message)

    def _network_tick(self) -> None:
        sample = self._station.teleoperation_command(self._now())
        if sample is None:
            return
        station, handle, desired_offset = self._station, sample.handle_position, sample.desired_offset
        pose = PoseStamped()
        pose.header.stamp = self.get_clock().now().to_msg()  # sampling time: the channel keeps it
        pose.header.frame_id = self._frame_id
        pose.pose.position = Point(x=float(handle[0]), y=float(handle[1]), z=float(handle[2]))
        o = pose.pose.orientation
        o.x, o.y, o.z, o.w = station.handle_orientation
        self._pose_publisher.publish(pose)
        self._command_publisher.publish(TeleoperationCommand(
            header=pose.header, mode=sample.mode, haptic_gain=sample.haptic_gain,
            workspace_scale=sample.workspace_scale, velocity_gain=sample.velocity_gain,
            handle_position=pose.pose.position,
            desired_offset=Point(x=float(desired_offset[0]), y=float(desired_offset[1]), z=float(desired_offset[2]))))
        observer = station.channel_port.observer  # E_in travels with x_d' (x: E_in, y: E_out, z: W of this port)
        energy = Vector3Stamped(header=pose.header)
        energy.vector.x, energy.vector.y, energy.vector.z = observer.input_energy, observer.output_energy, \
            observer.energy
        self._port_energy_publisher.publish(energy)

    def _publish_tools(self) -> None:
        station = self._station
        message = OperatorTools(engagement=int(station.engagement),
                                workspace_scale=float(station.integrator.workspace_scale),
                                force_scale=float(station.law.force_scale),
                                haptic_gain=float(station.law.haptic_gain), loop_gain=float(station.loop_gain()))
        message.header.stamp = self.get_clock().now().to_msg()
        message.header.frame_id = self._frame_id
        goal = station.fixture_goal()
        if goal is None:
            goal = station.integrator.desired_offset
        else:
            message.fixture = int(station.fixture.kind)
        message.fixture_goal = Point(x=float(goal[0]), y=float(goal[1]), z=float(goal[2]))
        force = station.guidance_force
        message.guidance_force.x, message.guidance_force.y, message.guidance_force.z = (float(f) for f in force)
        self._tools_publisher.publish(message)

    def _publish_diagnostics(self) -> None:
        problems, values = self._station.diagnostics(self._now())
        status = DiagnosticStatus(name="master", hardware_id="haptic_device",
                                  level=DiagnosticStatus.WARN if problems else DiagnosticStatus.OK,
                                  message="; ".join(problems) if problems else "ok",
                                  values=[KeyValue(key=key, value=value) for key, value in values.items()])
        station = self._station
        array = DiagnosticArray(status=[status, channel_port_status("master", "backward",
                                                                    station.channel_port.diagnostics())])
        if station.exchanged is not None:
            array.status.append(exchanged_energy_status("master", station.exchanged.observer, "N s/m"))
        array.header.stamp = self.get_clock().now().to_msg()
        self._diagnostics_publisher.publish(array)


def main(args: list[str] | None = None) -> None:
    run_entry(ENTRY, args)


ENTRY = NodeEntry(MasterNode, "master", follow_sim_time=False)  # its timers: periodic.py


if __name__ == "__main__":
    main()
