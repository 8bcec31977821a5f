"""Planner node: the autonomous part x_d'' of the replica's command (paper Eqs. 5-6, docs/CONTROL_LAWS.md).

A trajectory source (fic_core.trajectories: the paper's circle, a fixed point or via-points, chosen by the
``trajectory`` parameter) gives the next trajectory point x_t(t); fic_core.HarmonicPlanner turns it into x_d'',
published as /planner/desired_pose (PoseStamped, panda_link0) at ``publish_rate``, with the planner's
acceleration on /planner/desired_accel (AccelStamped, same stamp) so that the replica can feed the superimposed
motion's inertia forward (an addition beyond the paper, see fic_core.replica). The replica superimposes it
on the operator's offset: x_d = x_d' + x_d''. x_d'' is an absolute position in the robot base frame; the planner
starts at ``start_position`` (empty: the trajectory's first point) and the trajectory's clock starts
``start_delay`` seconds after the node. The orientation is a fixed parameter (the planner plans positions).

Runtime changes (validated, refused with a reason): a new trajectory or trajectory parameter restarts the
trajectory's clock and the planner moves harmonically from where it is; a new natural_frequency or max_velocity
restarts the planner at its current position, at rest.
"""
from __future__ import annotations

import gc
import math

import numpy as np
import rclpy
from rclpy.signals import SignalHandlerOptions
from sim_bridge import stop_signals
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import AccelStamped, PoseStamped
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, SetParametersResult
from rclpy.exceptions import ParameterUninitializedException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.task import Future
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

# Submodule imports: from the repository root a bare `import fic_core` finds the project folder fic_core/ as a
# namespace package first (the editable install resolves submodules only).
from fic_core.errors import FicInputError
from fic_core.planner import HarmonicPlanner
from fic_core.trajectories import Circle, FixedPoint, ViaPoints

# Poses (docs/CONVENTIONS.md): RELIABLE, KEEP_LAST 20.
POSE_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=20)
DIAGNOSTICS_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=10)

TRAJECTORIES = ("circle", "fixed", "via_points")
TRAJECTORY_PARAMETERS = ("trajectory", "circle_centre", "circle_diameter", "circle_period", "circle_normal",
                         "circle_phase", "fixed_point", "via_points", "via_dwell", "via_tolerance", "via_loop")
PLANNER_PARAMETERS = ("natural_frequency", "max_velocity")
READ_ONLY = ("publish_rate", "diagnostics_rate", "frame_id", "start_position", "start_delay", "start_time")


def _number(low: float, high: float, text: str, read_only: bool = False) -> ParameterDescriptor:
    return ParameterDescriptor(description=text, read_only=read_only, floating_point_range=[
        FloatingPointRange(from_value=low, to_value=high, step=0.0)])


def make_source(values: dict) -> Circle | FixedPoint | ViaPoints:
    """The trajectory source named by values['trajectory'] (raises FicInputError on bad values)."""
    kind = values["trajectory"]
    if kind == "circle":
        return Circle(values["circle_centre"], values["circle_diameter"], values["circle_period"],
                      values["circle_normal"], values["circle_phase"])
    if kind == "fixed":
        return FixedPoint(values["fixed_point"])
    if kind == "via_points":
        return ViaPoints(values["via_points"], values["via_dwell"], values["via_tolerance"], values["via_loop"])
    raise FicInputError(f"trajectory must be one of {TRAJECTORIES}, got {kind!r}")


def unit_quaternion(values) -> tuple[float, float, float, float]:
    quaternion = np.asarray(values, dtype=float)
    if quaternion.shape != (4,) or not np.all(np.isfinite(quaternion)) or np.linalg.norm(quaternion) < 1e-6:
        raise FicInputError(f"orientation must be a finite non-zero quaternion [x, y, z, w], got {list(values)}")
    quaternion = quaternion / np.linalg.norm(quaternion)
    return tuple(float(q) for q in quaternion)


class PlannerNode(Node):
    def __init__(self) -> None:
        super().__init__("planner")
        self._declare_parameters()
        value = self._value
        self._source = make_source({name: value(name) for name in TRAJECTORY_PARAMETERS})
        self._orientation = unit_quaternion(value("orientation"))
        self._planner = HarmonicPlanner(value("natural_frequency"), value("max_velocity"))
        start = list(value("start_position"))
        self._planner.reset(start if start else self._source.point(0.0))
        self._frame_id = value("frame_id")
        # The trajectory's clock: an absolute start time lets another node (the operator script, which plans its
        # moves around the circle's obstacles) share the same origin; otherwise start_delay after this node.
        start_time = value("start_time")
        self._trajectory_origin = start_time if start_time >= 0.0 else self._now() + value("start_delay")
        self._last_step_time: float | None = None
        self._nominal_period = 1.0 / value("publish_rate")
        self._target = self._planner.position
        self._published = 0

        self._publisher = self.create_publisher(PoseStamped, "/planner/desired_pose", POSE_QOS)
        self._accel_publisher = self.create_publisher(AccelStamped, "/planner/desired_accel", POSE_QOS)
        self._diagnostics_publisher = self.create_publisher(DiagnosticArray, "/diagnostics", DIAGNOSTICS_QOS)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.create_timer(1.0 / value("publish_rate"), self._tick)
        self.create_timer(1.0 / value("diagnostics_rate"), self._publish_diagnostics)
        self.get_logger().info(
            f"planner up: trajectory {value('trajectory')}, w_n = {value('natural_frequency')} rad/s, "
            f"v_d = {value('max_velocity')} m/s, start {np.round(self._planner.position, 4).tolist()}")

    # -- parameters -----------------------------------------------------------------------------------------
    def _declare_parameters(self) -> None:
        self.declare_parameter("trajectory", "circle", ParameterDescriptor(
            description=f"trajectory source: one of {TRAJECTORIES}"))
        self.declare_parameter("circle_centre", [0.45, 0.0, 0.35], ParameterDescriptor(
            description="centre of the circle [m] in panda_link0 (default: the E1 scene's, between the obstacles)"))
        self.declare_parameter("circle_diameter", 0.20, _number(0.001, 2.0, "circle diameter [m] (paper: 0.20)"))
        self.declare_parameter("circle_period", 5.0, _number(0.1, 600.0, "circle period [s] (paper: 5)"))
        self.declare_parameter("circle_normal", [0.0, 0.0, 1.0], ParameterDescriptor(
            description="normal of the circle's plane (default +z: horizontal, counter-clockwise from above)"))
        self.declare_parameter("circle_phase", 0.0, _number(-2 * math.pi, 2 * math.pi, "start angle [rad]"))
        self.declare_parameter("fixed_point", [0.45, 0.0, 0.35], ParameterDescriptor(
            description="target of the fixed trajectory [m] in panda_link0"))
        self.declare_parameter("via_points", [0.45, 0.1, 0.35, 0.45, -0.1, 0.35], ParameterDescriptor(
            description="via-points as a flat list x0, y0, z0, x1, ... [m] in panda_link0"))
        self.declare_parameter("via_dwell", 1.0, _number(0.0, 600.0,
                               "time a via-point is held once reached before the next [s]"))
        self.declare_parameter("via_tolerance", 0.002, _number(1e-5, 1.0, "a via-point is reached within this [m]"))
        self.declare_parameter("via_loop", True, ParameterDescriptor(
            description="start the via-points again after the last one"))
        self.declare_parameter("natural_frequency", 8.0, _number(0.1, 100.0, "w_n of the planner [rad/s] (Eq. 5)"))
        self.declare_parameter("max_velocity", 0.25, _number(0.001, 1.7,
                               "v_d: desired tangential velocity and speed limit [m/s] (Eq. 6); Panda TCP <= 1.7"))
        self.declare_parameter("orientation", [1.0, 0.0, 0.0, 0.0], ParameterDescriptor(
            description="fixed desired orientation [x, y, z, w] in panda_link0 (default: gripper down, a rotation "
                        "of pi about x as in the Panda's ready pose)"))
        self.declare_parameter("start_position", Parameter.Type.DOUBLE_ARRAY, ParameterDescriptor(
            description="x_d'' at start [m]; unset or empty: the trajectory's first point", read_only=True))
        self.declare_parameter("start_delay", 0.0, _number(0.0, 3600.0,
                               "the trajectory's clock starts this long after the node [s]", True))
        self.declare_parameter("start_time", -1.0, _number(-1.0, 1e10,
                               "node-clock time at which the trajectory's clock starts [s] (sim time with "
                               "use_sim_time); negative: start_delay after the node starts", True))
        self.declare_parameter("publish_rate", 250.0, _number(1.0, 5000.0, "/planner/desired_pose rate [Hz]", True))
        self.declare_parameter("diagnostics_rate", 1.0, _number(0.01, 100.0, "/diagnostics rate [Hz]", True))
        self.declare_parameter("frame_id", "panda_link0", ParameterDescriptor(
            description="frame of /planner/desired_pose", read_only=True))

    def _value(self, name: str):
        """A parameter's value; an array declared without a default and left unset reads as empty."""
        try:
            return self.get_parameter(name).value
        except ParameterUninitializedException:
            return []

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        changed = {p.name: p.value for p in parameters}
        for name, new in changed.items():
            if name in READ_ONLY:
                return SetParametersResult(successful=False, reason=f"{name} is fixed at start")
            if isinstance(new, float) and not math.isfinite(new):
                return SetParametersResult(successful=False, reason=f"{name} must be finite, got {new}")
        values = {name: self._value(name) for name in TRAJECTORY_PARAMETERS + PLANNER_PARAMETERS}
        values.update(changed)
        try:
            source = make_source(values) if any(n in TRAJECTORY_PARAMETERS for n in changed) else None
            planner = (HarmonicPlanner(values["natural_frequency"], values["max_velocity"])
                       if any(n in PLANNER_PARAMETERS for n in changed) else None)
            orientation = unit_quaternion(changed["orientation"]) if "orientation" in changed else None
        except (FicInputError, ValueError, TypeError) as error:
            return SetParametersResult(successful=False, reason=str(error))
        if source is not None:
            self._source = source
            self._trajectory_origin = self._now()
            self.get_logger().info(f"trajectory changed to {values['trajectory']}: its clock restarts")
        if planner is not None:
            planner.reset(self._planner.position)
            self._planner = planner
            self.get_logger().info(f"planner retuned: w_n = {values['natural_frequency']} rad/s, "
                                   f"v_d = {values['max_velocity']} m/s (restarts at rest where it is)")
        if orientation is not None:
            self._orientation = orientation
        return SetParametersResult(successful=True)

    # -- loop -----------------------------------------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _tick(self) -> None:
        now = self._now()
        if self._last_step_time is not None and now > self._last_step_time:
            # A late timer (a loaded machine, a slow sim clock) must not change the planner's dynamics: integrate
            # in steps no longer than the nominal period, sampling the trajectory at each.
            elapsed = now - self._last_step_time
            steps = max(1, math.ceil(elapsed / self._nominal_period - 1e-9))
            for k in range(1, steps + 1):
                sample_time = self._last_step_time + elapsed * k / steps
                trajectory_time = max(sample_time - self._trajectory_origin, 0.0)
                self._target = self._source.point(trajectory_time, position=self._planner.position)
                self._planner.step(self._target, elapsed / steps)
        if self._last_step_time is None or now > self._last_step_time:
            self._last_step_time = now
        position = self._planner.position
        message = PoseStamped()
        message.header.stamp = self.get_clock().now().to_msg()
        message.header.frame_id = self._frame_id
        message.pose.position.x, message.pose.position.y, message.pose.position.z = (float(p) for p in position)
        (message.pose.orientation.x, message.pose.orientation.y, message.pose.orientation.z,
         message.pose.orientation.w) = self._orientation
        self._publisher.publish(message)
        accel = AccelStamped()
        accel.header = message.header
        accel.accel.linear.x, accel.accel.linear.y, accel.accel.linear.z = (float(a) for a in self._planner.acceleration)
        self._accel_publisher.publish(accel)
        self._published += 1

    def _publish_diagnostics(self) -> None:
        status = DiagnosticStatus(name="planner", hardware_id="planner", level=DiagnosticStatus.OK, message="ok")
        status.values = [
            KeyValue(key="trajectory", value=str(self.get_parameter("trajectory").value)),
            KeyValue(key="target", value=" ".join(f"{v:.4f}" for v in self._target)),
            KeyValue(key="position", value=" ".join(f"{v:.4f}" for v in self._planner.position)),
            KeyValue(key="tracking_lag_m", value=f"{np.linalg.norm(self._target - self._planner.position):.4f}"),
            KeyValue(key="speed_m_s", value=f"{np.linalg.norm(self._planner.velocity):.4f}"),
            KeyValue(key="phase", value=" ".join(str(int(p)) for p in self._planner.phase)),
            KeyValue(key="published", value=str(self._published)),
        ]
        array = DiagnosticArray()
        array.header.stamp = self.get_clock().now().to_msg()
        array.status = [status]
        self._diagnostics_publisher.publish(array)


def main(args: list[str] | None = None) -> None:
    stop_signals.install()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)  # our handlers: stop_signals.py
    node = None
    try:
        node = PlannerNode()
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
        stop_signals.running()  # a signal now only asks the loop to stop; the node is destroyed before the context
        while rclpy.ok(context=node.context) and not stop_signals.requested():
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
