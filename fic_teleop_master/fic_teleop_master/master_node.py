"""Master node: the haptic device's FIC with the replica's force fed back (paper Eq. 3), and the teleoperation
command (offset or velocity mode, SPEC 1.3) sent to the replica through the channel.

Data path: /haptic/pose (x_M, haptic_base) + /haptic/twist + /master/feedback_wrench (F_R, delayed by the channel)
-> fic_core.MasterLaw -> /haptic/wrench_command (f = FIC(-x_M) + K_H*F_R) at ``control_rate``;
x_M -> fic_core.TeleoperationCommandIntegrator -> /master/pose and /master/teleop_command at ``network_rate``.
The haptic_base axes are taken as aligned with panda_link0's (the simulated device is set up that way), so F_R
is added to the device force without rotation.

Operator inputs: /operator/joy buttons (rising edges) 0: toggle OFFSET/VELOCITY, 1: K_H + 0.1, 2: K_H - 0.1;
/master/haptic_gain (std_msgs/Float64); or ``ros2 param set /master haptic_gain 0.3``. K_H outside [0, 1] is
clamped to it with a warning; NaN is refused.
"""
from __future__ import annotations

import gc
import math

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, PoseStamped, TwistStamped, WrenchStamped
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.task import Future
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Joy
from std_msgs.msg import Float64

# Submodule imports: from the repository root a bare `import fic_core` finds the project folder fic_core/ as a
# namespace package first (the editable install resolves submodules only).
from fic_core.attractor import FractalAttractor
from fic_core.errors import FicInputError
from fic_core.master import MasterLaw
from fic_core.profile import ForceProfile
from fic_core.teleoperation import TeleoperationCommandIntegrator, TeleoperationMode
from fic_teleop_msgs.msg import TeleoperationCommand

# Device streams at 500 Hz and teleoperation streams through the channel (docs/CONVENTIONS.md): RELIABLE,
# KEEP_LAST 20; the channel is where loss is injected on purpose, DDS itself should add none.
STREAM_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=20)
# Button presses are events: a lost toggle would invert the mode for the rest of the run.
JOY_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=50)
DIAGNOSTICS_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=10)

BUTTON_TOGGLE_MODE, BUTTON_GAIN_UP, BUTTON_GAIN_DOWN = 0, 1, 2
HAPTIC_GAIN_STEP = 0.1
#: Parameters of the handle's FIC profile (Eq. 1); changing one rebuilds the attractor (phase reset).
PROFILE_PARAMETERS = ("stiffness", "saturation_error", "saturation_start", "max_force", "rate_deadband")
#: Rates and frames are fixed at start (timers and message frames are created from them).
READ_ONLY = ("control_rate", "network_rate", "diagnostics_rate", "frame_id")


def _number(low: float, high: float, text: str, read_only: bool = False) -> ParameterDescriptor:
    return ParameterDescriptor(description=text, read_only=read_only, floating_point_range=[
        FloatingPointRange(from_value=low, to_value=high, step=0.0)])


def _vector(message) -> np.ndarray:
    return np.array([message.x, message.y, message.z], dtype=float)


class MasterNode(Node):
    def __init__(self) -> None:
        super().__init__("master")
        self._declare_parameters()
        value = lambda name: self.get_parameter(name).value  # noqa: E731
        self._master = MasterLaw(self._attractor_from(value), 0.0, self._device_limit(value("max_device_force")))
        self._apply_haptic_gain(value("haptic_gain"), source="parameter")
        self._integrator = TeleoperationCommandIntegrator(value("workspace_scale"), value("velocity_gain"),
                                                          value("mode"), value("velocity_deadband"))
        self._frame_id = value("frame_id")
        self._feedback_timeout = value("feedback_timeout")
        self._pose_timeout = value("pose_timeout")

        self._handle_position: np.ndarray | None = None  # x_M, last good
        self._handle_orientation = (0.0, 0.0, 0.0, 1.0)
        self._handle_velocity = np.zeros(3)
        self._pose_received_at: float | None = None
        self._twist_received_at: float | None = None
        self._previous_pose: tuple[float, np.ndarray] | None = None  # for velocity by differencing
        self._replica_force = np.zeros(3)
        self._feedback_received_at: float | None = None
        self._feedback_stale_warned = False
        self._previous_buttons: list[int] = []
        self._last_network_time: float | None = None
        self._wrench_count = 0
        self._saturated_count = 0

        self._wrench_publisher = self.create_publisher(WrenchStamped, "/haptic/wrench_command", STREAM_QOS)
        self._pose_publisher = self.create_publisher(PoseStamped, "/master/pose", STREAM_QOS)
        self._command_publisher = self.create_publisher(TeleoperationCommand, "/master/teleop_command", STREAM_QOS)
        self._diagnostics_publisher = self.create_publisher(DiagnosticArray, "/diagnostics", DIAGNOSTICS_QOS)
        self.create_subscription(PoseStamped, "/haptic/pose", self._on_pose, STREAM_QOS)
        self.create_subscription(TwistStamped, "/haptic/twist", self._on_twist, STREAM_QOS)
        self.create_subscription(WrenchStamped, "/master/feedback_wrench", self._on_feedback, STREAM_QOS)
        self.create_subscription(Joy, "/operator/joy", self._on_joy, JOY_QOS)
        self.create_subscription(Float64, "/master/haptic_gain", self._on_haptic_gain, STREAM_QOS)
        self.add_pre_set_parameters_callback(self._clamp_haptic_gain)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        if value("haptic_gain") != self._master.haptic_gain:  # clamped at start: make `param get` show it
            self._sync_haptic_gain_parameter()
        self.create_timer(1.0 / value("control_rate"), self._control_tick)
        self.create_timer(1.0 / value("network_rate"), self._network_tick)
        self.create_timer(1.0 / value("diagnostics_rate"), self._publish_diagnostics)
        self.get_logger().info(
            f"master up: K_H = {self._master.haptic_gain:.2f}, mode {self._integrator.mode.name}, "
            f"control {value('control_rate'):.0f} Hz, network {value('network_rate'):.0f} Hz")

    # -- parameters -----------------------------------------------------------------------------------------
    def _declare_parameters(self) -> None:
        self.declare_parameter("stiffness", 100.0, _number(1.0, 5000.0, "K0 of the handle's FIC [N/m] (Eq. 1)"))
        self.declare_parameter("saturation_error", 0.04, _number(1e-3, 1.0, "x_b of the handle's FIC [m]"))
        self.declare_parameter("saturation_start", 0.5, _number(0.0, 0.99, "xi of the handle's FIC, in [0, 1)"))
        self.declare_parameter("max_force", 6.0, _number(0.1, 100.0, "F_max of the handle's FIC [N] (>= xi*K0*x_b)"))
        self.declare_parameter("rate_deadband", 0.005, _number(0.0, 1.0,
                               "dead-band on d|x_M|/dt for entering the convergence phase [m/s] (SPEC 1.2)"))
        self.declare_parameter("haptic_gain", 0.5, _number(0.0, 10.0,
                               "K_H: share of the replica force rendered on the handle (Eq. 3), in [0, 1]; "
                               "values above 1 are clamped to 1 with a warning"))
        self.declare_parameter("max_device_force", 20.0, _number(0.0, 1000.0,
                               "norm limit of the device force [N] (sigma.7: ~20 N continuous); 0: no limit"))
        self.declare_parameter("mode", int(TeleoperationMode.OFFSET), ParameterDescriptor(
            description="teleoperation mode: 0 offset (x_d' = s_M*x_M), 1 velocity (x_d' += k_v*x_M*dt)",
            integer_range=[IntegerRange(from_value=0, to_value=1, step=1)]))
        self.declare_parameter("workspace_scale", 1.0, _number(0.01, 100.0, "s_M: offset-mode scale"))
        self.declare_parameter("velocity_gain", 2.0, _number(0.0, 100.0, "k_v: velocity-mode gain [1/s]"))
        self.declare_parameter("velocity_deadband", 0.005, _number(0.0, 0.1,
                               "velocity mode ignores |x_M| below this [m] so a resting hand does not drift"))
        self.declare_parameter("feedback_timeout", 0.5, _number(0.001, 60.0,
                               "F_R older than this (receipt time) is treated as zero [s]"))
        self.declare_parameter("pose_timeout", 0.1, _number(0.001, 60.0,
                               "no /haptic/pose for this long: the wrench command is zero [s]"))
        self.declare_parameter("control_rate", 500.0, _number(1.0, 5000.0, "/haptic/wrench_command rate [Hz]", True))
        self.declare_parameter("network_rate", 100.0, _number(1.0, 5000.0,
                               "/master/pose and /master/teleop_command rate [Hz]", True))
        self.declare_parameter("diagnostics_rate", 1.0, _number(0.01, 100.0, "/diagnostics rate [Hz]", True))
        self.declare_parameter("frame_id", "haptic_base", ParameterDescriptor(
            description="frame of /master/pose and /haptic/wrench_command", read_only=True))

    @staticmethod
    def _attractor_from(value) -> FractalAttractor:
        profile = ForceProfile(value("stiffness"), value("saturation_error"), value("saturation_start"),
                               value("max_force"))
        return FractalAttractor(profile, 3, value("rate_deadband"))

    @staticmethod
    def _device_limit(value: float) -> float | None:
        return None if value == 0.0 else value

    def _clamp_haptic_gain(self, parameters: list[Parameter]) -> list[Parameter]:
        """Pre-set: K_H outside [0, 1] becomes the nearest bound (logged); NaN passes on to be refused."""
        result = []
        for parameter in parameters:
            if parameter.name == "haptic_gain" and parameter.type_ == Parameter.Type.DOUBLE:
                requested = parameter.value
                if math.isfinite(requested) and not 0.0 <= requested <= 1.0:
                    clamped = min(max(requested, 0.0), 1.0)
                    self.get_logger().warning(f"haptic_gain {requested} is outside [0, 1]: clamped to {clamped}")
                    parameter = Parameter("haptic_gain", Parameter.Type.DOUBLE, clamped)
            result.append(parameter)
        return result

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        values = {name: self.get_parameter(name).value for name in PROFILE_PARAMETERS}
        changed = {p.name: p.value for p in parameters}
        for name, new in changed.items():
            if name in READ_ONLY:
                return SetParametersResult(successful=False, reason=f"{name} is fixed at start")
            if isinstance(new, float) and not math.isfinite(new):
                return SetParametersResult(successful=False, reason=f"{name} must be finite, got {new}")
        try:
            attractor = None
            if any(name in PROFILE_PARAMETERS for name in changed):
                values.update({k: v for k, v in changed.items() if k in PROFILE_PARAMETERS})
                attractor = self._attractor_from(values.__getitem__)
            integrator_changes = {k: changed[k] for k in ("workspace_scale", "velocity_gain", "velocity_deadband")
                                  if k in changed}
            for key, new in integrator_changes.items():  # validate before applying anything
                TeleoperationCommandIntegrator(**{key: new})
        except FicInputError as error:
            return SetParametersResult(successful=False, reason=str(error))
        if attractor is not None:
            self._master = MasterLaw(attractor, self._master.haptic_gain, self._master.max_device_force)
            self.get_logger().info("handle FIC profile changed: attractor rebuilt (phase reset)")
        for key, new in changed.items():
            if key == "haptic_gain":
                self._apply_haptic_gain(new, source="parameter")
            elif key == "max_device_force":
                self._master.max_device_force = self._device_limit(new)
            elif key == "mode" and new != self._integrator.mode:
                self._integrator.set_mode(new)
                self.get_logger().info(f"teleoperation mode: {self._integrator.mode.name} (parameter)")
            elif key == "workspace_scale":
                self._integrator.workspace_scale = new
            elif key == "velocity_gain":
                self._integrator.velocity_gain = new
            elif key == "velocity_deadband":
                self._integrator.velocity_deadband = new
            elif key == "feedback_timeout":
                self._feedback_timeout = new
            elif key == "pose_timeout":
                self._pose_timeout = new
        return SetParametersResult(successful=True)

    def _apply_haptic_gain(self, value: float, source: str) -> None:
        if self._master.set_haptic_gain(value):
            self.get_logger().warning(f"haptic_gain {value} from {source} clamped to {self._master.haptic_gain}")

    def _sync_haptic_gain_parameter(self) -> None:
        self.set_parameters([Parameter("haptic_gain", Parameter.Type.DOUBLE, self._master.haptic_gain)])

    # -- inputs ---------------------------------------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_pose(self, message: PoseStamped) -> None:
        position = _vector(message.pose.position)
        orientation = message.pose.orientation
        quaternion = (orientation.x, orientation.y, orientation.z, orientation.w)
        if not (np.all(np.isfinite(position)) and all(math.isfinite(q) for q in quaternion)):
            self.get_logger().error("refused /haptic/pose with non-finite values; holding the last good pose",
                                    throttle_duration_sec=1.0)
            return
        now = self._now()
        if self._previous_pose is not None and not self._twist_fresh(now):
            previous_time, previous_position = self._previous_pose
            if now > previous_time:
                self._handle_velocity = (position - previous_position) / (now - previous_time)
        self._previous_pose = (now, position)
        self._handle_position = position
        self._handle_orientation = quaternion
        self._pose_received_at = now

    def _twist_fresh(self, now: float) -> bool:
        return self._twist_received_at is not None and now - self._twist_received_at <= self._pose_timeout

    def _on_twist(self, message: TwistStamped) -> None:
        velocity = _vector(message.twist.linear)
        if not np.all(np.isfinite(velocity)):
            self.get_logger().error("refused /haptic/twist with non-finite values", throttle_duration_sec=1.0)
            return
        self._handle_velocity = velocity
        self._twist_received_at = self._now()

    def _on_feedback(self, message: WrenchStamped) -> None:
        force = _vector(message.wrench.force)
        if not np.all(np.isfinite(force)):
            self.get_logger().error("refused /master/feedback_wrench with non-finite values",
                                    throttle_duration_sec=1.0)
            return
        self._replica_force = force
        self._feedback_received_at = self._now()
        if self._feedback_stale_warned:
            self.get_logger().info("/master/feedback_wrench is fresh again")
            self._feedback_stale_warned = False

    def _on_joy(self, message: Joy) -> None:
        buttons = list(message.buttons)
        previous = self._previous_buttons + [0] * max(0, len(buttons) - len(self._previous_buttons))
        pressed = [index for index, state in enumerate(buttons) if state and not previous[index]]
        self._previous_buttons = buttons
        if BUTTON_TOGGLE_MODE in pressed:
            mode = self._integrator.toggle_mode()
            self.get_logger().info(f"teleoperation mode: {mode.name} (button)")
            self.set_parameters([Parameter("mode", Parameter.Type.INTEGER, int(mode))])  # keep `param get` true
        step = HAPTIC_GAIN_STEP * ((BUTTON_GAIN_UP in pressed) - (BUTTON_GAIN_DOWN in pressed))
        if step:
            self._apply_haptic_gain(round(self._master.haptic_gain + step, 6), source="button")
            self._sync_haptic_gain_parameter()
            self.get_logger().info(f"haptic gain K_H = {self._master.haptic_gain:.2f} (button)")

    def _on_haptic_gain(self, message: Float64) -> None:
        try:
            self._apply_haptic_gain(message.data, source="/master/haptic_gain")
        except FicInputError as error:
            self.get_logger().error(f"refused /master/haptic_gain: {error}", throttle_duration_sec=1.0)
            return
        self._sync_haptic_gain_parameter()

    # -- outputs --------------------------------------------------------------------------------------------
    def _feedback_force(self, now: float) -> np.ndarray:
        """F_R, or zero (warned once per stale period) if it is older than feedback_timeout or never came."""
        if self._feedback_received_at is not None and now - self._feedback_received_at <= self._feedback_timeout:
            return self._replica_force
        if not self._feedback_stale_warned:
            age = "never received" if self._feedback_received_at is None else \
                f"{now - self._feedback_received_at:.2f} s old"
            self.get_logger().warning(f"/master/feedback_wrench is stale ({age}): rendering F_R = 0")
            self._feedback_stale_warned = True
        return np.zeros(3)

    def _control_tick(self) -> None:
        if self._handle_position is None:
            return  # no handle yet: nothing to render
        now = self._now()
        stamp = self.get_clock().now().to_msg()
        message = WrenchStamped()
        message.header.stamp = stamp
        message.header.frame_id = self._frame_id
        if now - self._pose_received_at <= self._pose_timeout:
            force = self._master.force(self._handle_position, self._handle_velocity, self._feedback_force(now))
            self._saturated_count += int(self._master.device_force_saturated)
        else:
            self.get_logger().warning("/haptic/pose is stale: commanding zero force", throttle_duration_sec=1.0)
            force = np.zeros(3)
        message.wrench.force.x, message.wrench.force.y, message.wrench.force.z = (float(f) for f in force)
        self._wrench_publisher.publish(message)
        self._wrench_count += 1

    def _network_tick(self) -> None:
        if self._handle_position is None:
            return
        now = self._now()
        dt = 0.0 if self._last_network_time is None else max(now - self._last_network_time, 0.0)
        self._last_network_time = now
        desired_offset = self._integrator.update(self._handle_position, dt)
        stamp = self.get_clock().now().to_msg()  # sampling time: the channel keeps it, the replica measures age
        pose = PoseStamped()
        pose.header.stamp = stamp
        pose.header.frame_id = self._frame_id
        pose.pose.position = Point(x=float(self._handle_position[0]), y=float(self._handle_position[1]),
                                   z=float(self._handle_position[2]))
        (pose.pose.orientation.x, pose.pose.orientation.y, pose.pose.orientation.z,
         pose.pose.orientation.w) = self._handle_orientation
        self._pose_publisher.publish(pose)
        command = TeleoperationCommand()
        command.header = pose.header
        command.mode = int(self._integrator.mode)
        command.haptic_gain = float(self._master.haptic_gain)
        command.workspace_scale = float(self._integrator.workspace_scale)
        command.velocity_gain = float(self._integrator.velocity_gain)
        command.handle_position = pose.pose.position
        command.desired_offset = Point(x=float(desired_offset[0]), y=float(desired_offset[1]),
                                       z=float(desired_offset[2]))
        self._command_publisher.publish(command)

    def _publish_diagnostics(self) -> None:
        now = self._now()
        status = DiagnosticStatus(name="master", hardware_id="haptic_device")
        problems = []
        if self._handle_position is None:
            problems.append("no /haptic/pose yet")
        elif now - self._pose_received_at > self._pose_timeout:
            problems.append("/haptic/pose stale")
        if self._feedback_stale_warned:
            problems.append("/master/feedback_wrench stale (F_R = 0)")
        status.level = DiagnosticStatus.WARN if problems else DiagnosticStatus.OK
        status.message = "; ".join(problems) if problems else "ok"
        feedback_age = math.inf if self._feedback_received_at is None else now - self._feedback_received_at
        status.values = [
            KeyValue(key="mode", value=self._integrator.mode.name),
            KeyValue(key="haptic_gain", value=f"{self._master.haptic_gain:.3f}"),
            KeyValue(key="feedback_age_s", value=f"{feedback_age:.3f}"),
            KeyValue(key="phase", value=" ".join(str(int(p)) for p in self._master.attractor.phase)),
            KeyValue(key="wrench_commands", value=str(self._wrench_count)),
            KeyValue(key="device_force_saturated_ticks", value=str(self._saturated_count)),
            KeyValue(key="desired_offset", value=" ".join(f"{v:.4f}" for v in self._integrator.desired_offset)),
        ]
        array = DiagnosticArray()
        array.header.stamp = self.get_clock().now().to_msg()
        array.status = [status]
        self._diagnostics_publisher.publish(array)


def main(args: list[str] | None = None) -> None:
    rclpy.init(args=args)
    node = None
    try:
        node = MasterNode()
        spin_until_shutdown(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()


def spin_until_shutdown(node: Node, slice_s: float = 0.1) -> None:
    """Spin on the EventsExecutor in short slices until Ctrl-C / SIGTERM / external shutdown.

    ``EventsExecutor.spin()`` from the rclpy wheels does not return after SIGINT (see sim_bridge/spin.py);
    checking the context between short ``spin_once`` slices exits within one slice.
    """
    # Under simulated time (lockstep) the EventsExecutor's timers do not follow /clock: measured here, the master's
    # 100 Hz timer fired in bursts (10 commands with one stamp) and then fell silent for 100 ms of simulated time.
    # The wait-set executor checks timers against the node's clock, so timer ticks land on simulated time.
    executor = (SingleThreadedExecutor(context=node.context) if node.get_parameter("use_sim_time").value
                else EventsExecutor(context=node.context))
    executor.add_node(node)
    # The start-up heap (rclpy, numpy, Pinocchio, MuJoCo: ~60k objects) moved out of the collector's reach: a
    # full collection of it took 25 ms here, and with it every loop in the graph stalled every few seconds.
    gc.collect()
    gc.freeze()
    try:
        # A slice runs every callback due in it inside the executor, not one per Python call: a 1 kHz timer cost
        # 77-82 us a tick here against 92-101 us with spin_once (the future never completes; the slice bounds the wait).
        never = Future()
        while rclpy.ok(context=node.context):
            try:
                executor.spin_until_future_complete(never, timeout_sec=slice_s)
            except (KeyboardInterrupt, ExternalShutdownException):
                break
            except Exception:
                # A callback that ran while the signal handler was shutting the context down (a timer's publish
                # on the invalidated context, a pybind11 conversion error in a take) is not a fault of the node.
                if rclpy.ok(context=node.context):
                    raise
                break
    finally:
        executor.shutdown(timeout_sec=1.0)


if __name__ == "__main__":
    main()
