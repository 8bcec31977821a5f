"""ROS 2 shell around fic_core's replica law (paper Eq. 7 + postural optimisation, SPEC 1.5).

Data path (docs/CONVENTIONS.md):
    /joint_states (1 kHz)  ---------------------------------\\
    /replica/teleop_command (x_d', delayed by the channel) --+--> x_d = x_d' + x_d'' --> ReplicaController
    /planner/desired_pose (x_d'')  --------------------------/                                |
    /effort_controller/commands (7 torques) <-------------------------------------------------/
    /ft_sensor/wrench (F_R) --> /replica/feedback_wrench (250 Hz, to the channel and the master)

- The control step runs on each /joint_states message (event-driven: the simulator's realtime and lockstep modes
  alike; in lockstep the simulator waits for the command of each step). With ``control_rate`` below the joint
  state rate the law runs every 1/control_rate seconds of joint-state time and the last torque is held in
  between, published on every joint state so lockstep still advances. The published torque is slewed at the
  Panda's torque-rate limit (1000 N m/s over ``command_period``), so a slow controller's steps never break it.
- Set-points between samples (fic_core.set_point): x_d' (100 Hz through the channel) and x_d'' (100 Hz) are
  first-order holds on their senders' stamps, so x_d moves smoothly at the control rate; the acceleration of both
  (the planner's own, the teleoperated offset's estimated) is fed forward through J^T Lambda, and D qd (the arm's viscous joint
  friction) is added to tau_d (``planner_feedforward``, ``offset_feedforward``, ``joint_damping_compensation``;
  all beyond paper Eq. 7, none depends on the tracking error).
- Watchdog: teleoperation commands not received for ``master_timeout`` -> x_d' is held (said once, as a warning);
  when they return, the jump between the held and the new x_d' is given back at ``resume_speed`` instead of
  jumping, while x_d' follows the new commands underneath.
- No planner yet -> x_d'' is the TCP pose at the first joint state; then the jump to the planner's first pose is
  given back at ``resume_speed``; a silent planner -> its last value.
- Before the first joint state nothing is published. Messages with NaN/Inf are refused (throttled error log) and
  the last good value is kept. Parameters are validated at start and when changed at run time.
"""
from __future__ import annotations

import gc
import math
import struct

import numpy as np
import pinocchio as pin
import rclpy
from rclpy.serialization import deserialize_message
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from fic_teleop_msgs.msg import FicState, LimitStatus, TeleoperationCommand
from geometry_msgs.msg import AccelStamped, PoseStamped, WrenchStamped
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, SetParametersResult
from rclpy._rclpy_pybind11 import RCLError
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.task import Future
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from fic_core.attractor import PoseAttractor
from fic_core.baseline import LinearImpedance
from fic_core.errors import FicInputError
from fic_core.limits import PandaLimits
from fic_core.postural_optimisation import PosturalOptimisation
from fic_core.posture import NullSpacePosture
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController, rotation_from_quaternion
from fic_core.robot_model import RobotModel
from fic_core.set_point import SampledSetPoint, ShrinkingOffset
from fic_core.panda_description import ARM_JOINT_NAMES

# 1 kHz robot streams: RELIABLE, KEEP_LAST 50 (a recorder must lose none; a late command is superseded anyway).
ROBOT_STREAM_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=50)
# Teleoperation streams through the channel: loss is the channel's job, DDS should add none.
# The replica's own view of the robot: only the newest state matters. A deep reader queue would, on a busy
# machine, hand the control law a backlog of old states and send torques computed for the past, a delayed
# feedback loop that the physics then integrates (measured: the arm was thrown about under overload). Lockstep
# is unaffected: the sim publishes the next state only after this node answered the last. BEST_EFFORT (it matches
# the robot's RELIABLE writer): a reliable reader delivers in order, so one sample lost between processes held
# every later state back until the writer's heartbeat repaired it (seen here: 50-90 ms without joint states);
# a newer state is worth more than a repaired old one.
NEWEST_STATE_QOS = QoSProfile(reliability=ReliabilityPolicy.BEST_EFFORT, history=HistoryPolicy.KEEP_LAST, depth=1)
# Set-points (x_d' through the channel, x_d'' from the planner): RELIABLE (no loss but the channel's), depth 1 on
# this side: only the newest is used, and a deeper queue behind a busy replica handed it commands up to
# depth x period old (measured: a pipeline-latency p99 of about 200 ms with depth 20 at 100 Hz).
TELEOP_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=1)
# Status streams (fic_state, limit_status, poses, feedback wrench).
STATUS_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=20)
DIAGNOSTICS_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=10)

BASE_FRAME = "panda_link0"
NODE_NAME = "replica"
LOG_THROTTLE_S = 2.0
# An older planner acceleration is not fed forward (the planner publishes at 100 Hz).
FEEDFORWARD_TIMEOUT_S = 0.05
# A longer interval between two control ticks (a stall, a restart) is taken as one nominal period.
MAX_CONTROL_INTERVAL_S = 0.1
# A sample gap longer than this restarts a set-point's velocity and acceleration estimates from rest [s].
SET_POINT_MAX_GAP_S = 0.1

# name: (default, description, low, high) -- config/replica.yaml holds the same defaults.
NUMBERS: dict[str, tuple[float, str, float, float]] = {
    "translation_stiffness": (200.0, "FIC K0 of translation [N/m] (paper Sec. III: 200)", 1.0, 1.0e5),
    "translation_saturation_error": (0.05, "FIC x_b of translation [m] (paper: 0.05)", 1.0e-4, 1.0),
    "translation_saturation_start": (0.5, "FIC xi of translation, in [0, 1)", 0.0, 0.99),
    "translation_max_force": (15.0, "FIC F_max of translation [N], >= xi*K0*x_b", 0.01, 500.0),
    "rotation_stiffness": (20.0, "FIC K0 of rotation [N m/rad]", 0.1, 1.0e4),
    "rotation_saturation_error": (0.5, "FIC x_b of rotation [rad]", 1.0e-3, 3.14),
    "rotation_saturation_start": (0.5, "FIC xi of rotation, in [0, 1)", 0.0, 0.99),
    "rotation_max_force": (5.0, "FIC F_max of rotation [N m], >= xi*K0*x_b", 0.01, 100.0),
    "rate_deadband_translation": (0.005, "FIC dead-band on d|e|/dt for entering C, translation [m/s]", 0.0, 1.0),
    "rate_deadband_rotation": (0.005, "FIC dead-band on d|e|/dt for entering C, rotation [rad/s]", 0.0, 10.0),
    "linear_translation_damping": (39.6, "baseline (controller: linear) damping [N s/m]; K = translation_stiffness",
                                   0.0, 1.0e4),
    "linear_rotation_damping": (1.98, "baseline damping of rotation [N m s/rad]; K = rotation_stiffness",
                                0.0, 1.0e3),
    "posture_stiffness": (10.0, "null-space pull toward the nominal configuration [N m/rad]", 0.0, 500.0),
    "posture_damping": (2.0, "null-space joint damping [N m s/rad]", 0.0, 100.0),
    "posture_limit_band": (0.2, "joint-limit repulsion acts within this distance of a URDF limit [rad]", 0.01, 1.0),
    "posture_limit_stiffness": (50.0, "joint-limit repulsion gain [N m/rad]", 0.0, 1000.0),
    "velocity_horizon": (0.05, "horizon of the velocity-limit predictions of the postural optimisation [s]",
                         0.001, 1.0),
    "control_rate": (1000.0, "control law rate [Hz]; below the joint-state rate the torque is held in between",
                     1.0, 1000.0),
    "command_period": (0.001, "period of /joint_states and of the published commands [s] (torque slew step)",
                       1.0e-4, 0.1),
    "master_timeout": (0.5, "teleoperation commands older than this (by receipt) are stale: x_d' is held [s]",
                       0.01, 60.0),
    "resume_speed": (0.1, "speed at which x_d' moves to the commanded value after a stale period [m/s]",
                     0.001, 2.0),
    "set_point_acceleration_filter": (0.05, "time constant of the acceleration estimate of x_d' (fed forward when "
                                            "offset_feedforward is true) [s]", 0.0, 1.0),
    "set_point_extrapolation": (0.015, "x_d' and x_d'' move on along their last velocity for at most this long "
                                      "after a sample (first-order hold between samples) [s]; 0: held as steps",
                                0.0, 0.5),
    "desired_velocity_filter": (0.02, "time constant of the x_d velocity estimate fed to the FIC's error rate [s]; "
                                      "0 disables it (zero desired twist)", 0.0, 1.0),
    "pose_rate": (100.0, "rate of /replica/desired_pose, /replica/tcp_pose, /replica/feedback_wrench [Hz]",
                  1.0, 1000.0),
    "status_rate": (100.0, "rate of /replica/fic_state and /replica/limit_status [Hz]; LimitStatus flags are OR-ed "
                           "over the ticks since the last message and its tick counters are cumulative, so a lower "
                           "rate loses no count", 1.0, 1000.0),
    "diagnostics_rate": (1.0, "rate of /diagnostics [Hz]", 0.1, 10.0),
}
CONTROLLERS = ("fic", "linear")
# builtin_interfaces/Time (int32 sec, uint32 nanosec) at the start of a CDR message with a std_msgs/Header.
STAMP_LITTLE_ENDIAN = struct.Struct("<iI")
STAMP_BIG_ENDIAN = struct.Struct(">iI")


def _finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


def _seconds(stamp: Time) -> float:
    return stamp.sec + 1e-9 * stamp.nanosec


class ReplicaNode(Node):
    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        self._declare_parameters()
        self._robot = RobotModel()
        self._limits = PandaLimits.from_robot(self._robot)
        self._replica = self._build_replica(self._parameter_values())  # raises FicInputError on bad parameters
        self._index_cache: dict[tuple[str, ...], np.ndarray] = {}
        # State.
        self._started = False
        self._start_position = np.zeros(3)
        self._start_rotation = np.eye(3)
        self._planner_position: np.ndarray | None = None   # x_d'' as last received
        self._planner_in_use: np.ndarray | None = None     # x_d'' in use (the first pose's jump given back)
        self._planner_hold = self._set_point_hold()        # x_d'' between samples (fic_core.set_point)
        self._planner_jump = ShrinkingOffset()             # start pose - first planner pose, given back
        self._planner_acceleration: np.ndarray | None = None
        self._planner_acceleration_received = 0.0
        self._planner_rotation: np.ndarray | None = None
        self._commanded_offset = np.zeros(3)   # x_d' as last received
        self._offset = np.zeros(3)             # x_d' in use (held while stale, blended on resume)
        self._offset_hold = self._set_point_hold()          # x_d' between samples
        self._offset_jump = ShrinkingOffset()               # x_d' held - x_d' commanded at a resume, given back
        self._master_stamp = Time()
        self._master_received: float | None = None  # node-clock seconds of the last good teleop command
        self._master_stale = False
        self._wrench = WrenchStamped()
        self._wrench.header.frame_id = BASE_FRAME
        self._last_control_time: float | None = None
        self._last_pose_time: float | None = None
        self._last_status_time: float | None = None
        self._shaping_since_status = 0      # LimitStatus flags OR-ed over the ticks since the last message
        self._violations_since_status = 0
        self._master_stamp_used = Time()    # the teleop command the last control tick used
        self._master_first_use_age = 0.0    # its age at the control tick that first used it [s]
        self._held_torque: np.ndarray | None = None   # the law's last output
        self._published_torque: np.ndarray | None = None
        self._published_time: float | None = None     # joint-state time of the last published command
        self._previous_desired: np.ndarray | None = None
        self._desired_velocity = np.zeros(3)
        self._last_command = None
        self._counts = {"joint_states": 0, "control_ticks": 0, "teleop_commands": 0, "planner_poses": 0,
                        "wrenches": 0, "rejected_joint_states": 0,
                        "rejected_teleop_commands": 0, "rejected_planner_poses": 0, "rejected_wrenches": 0,
                        "controller_errors": 0}
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
        self._diagnostics_timer = self.create_timer(1.0 / self._p["diagnostics_rate"], self._publish_diagnostics)
        self.get_logger().info(
            f"replica ready: controller {self._p['controller']}, control_rate {self._p['control_rate']:g} Hz, "
            f"master_timeout {self._p['master_timeout']:g} s; waiting for /joint_states")

    # --- parameters ------------------------------------------------------------------------------------------
    def _declare_parameters(self) -> None:
        self.declare_parameter("controller", "fic", ParameterDescriptor(
            description="task-space law: 'fic' (the paper's Fractal Impedance Controller) or 'linear' (the "
                        "baseline spring-damper with the same stiffness)"))
        self.declare_parameter("answer_every_state", False, ParameterDescriptor(
            description="publish a command for every joint state (the held torque between control ticks), as the "
                        "simulator's lockstep mode needs; false: only at control ticks, the robot holding the last "
                        "command in between (realtime; saves a 1 kHz stream when control_rate is below 1 kHz)"))
        self.declare_parameter("tick_on_command", False, ParameterDescriptor(
            description="also run a control tick at the first joint state after a new teleoperation command, instead "
                        "of waiting for the control_rate grid, which restarts from that tick: the command is "
                        "applied up to one control period sooner, for at most one extra tick per command (the "
                        "launcher sets it with --scheduling fifo; off, the law runs at control_rate exactly, as the "
                        "bandwidth sweep needs)"))
        self.declare_parameter("planner_feedforward", True, ParameterDescriptor(
            description="feed the planner's acceleration (/planner/desired_accel) forward through the task-space "
                        "inertia, J^T Lambda a_d (beyond paper Eq. 7: the FIC compensates no inertia)"))
        self.declare_parameter("offset_feedforward", True, ParameterDescriptor(
            description="feed the estimated acceleration of the teleoperated x_d' forward the same way (beyond paper "
                        "Eq. 7; fic_core.set_point: from the stamps of successive commands, low-pass filtered)"))
        self.declare_parameter("joint_damping_compensation", True, ParameterDescriptor(
            description="add D qd, the arm's viscous joint friction, to tau_d as Eq. 7 adds C qd (beyond the paper; "
                        "fic_core.replica)"))
        self.declare_parameter("use_planner_orientation", False, ParameterDescriptor(
            description="track the orientation of /planner/desired_pose; false holds the TCP orientation found at "
                        "start (the planner plans positions, paper Eqs. 5-6)"))
        for name, (default, description, low, high) in NUMBERS.items():
            self.declare_parameter(name, default, ParameterDescriptor(
                description=description,
                floating_point_range=[FloatingPointRange(from_value=low, to_value=high, step=0.0)]))
        self._p = self._parameter_values()

    def _parameter_values(self, overrides: dict | None = None) -> dict:
        values = {name: self.get_parameter(name).value for name in (*NUMBERS, "controller", "use_planner_orientation",
                                                                   "planner_feedforward", "offset_feedforward",
                                                                   "joint_damping_compensation",
                                                                   "answer_every_state", "tick_on_command")}
        values.update(overrides or {})
        for name in NUMBERS:
            values[name] = float(values[name])
        return values

    def _build_replica(self, p: dict) -> ReplicaController:
        """A ReplicaController for parameters ``p``; FicInputError (naming the parameter) if they are invalid."""
        for name in NUMBERS:
            low, high = NUMBERS[name][2], NUMBERS[name][3]
            if not math.isfinite(p[name]) or not low <= p[name] <= high:
                raise FicInputError(f"{name} must be a finite number in [{low:g}, {high:g}], got {p[name]}")
        if p["controller"] not in CONTROLLERS:
            raise FicInputError(f"controller must be one of {CONTROLLERS}, got {p['controller']!r}")
        if p["controller"] == "fic":
            controller = PoseAttractor(
                ForceProfile(p["translation_stiffness"], p["translation_saturation_error"],
                             p["translation_saturation_start"], p["translation_max_force"]),
                ForceProfile(p["rotation_stiffness"], p["rotation_saturation_error"], p["rotation_saturation_start"],
                             p["rotation_max_force"]),
                p["rate_deadband_translation"], p["rate_deadband_rotation"])
        else:
            controller = LinearImpedance(p["translation_stiffness"], p["rotation_stiffness"],
                                         p["linear_translation_damping"], p["linear_rotation_damping"])
        robot = self._robot
        posture = NullSpacePosture(robot.lower_position_limit, robot.upper_position_limit,
                                   stiffness=p["posture_stiffness"], damping=p["posture_damping"],
                                   limit_band=p["posture_limit_band"], limit_stiffness=p["posture_limit_stiffness"])
        period = 1.0 / p["control_rate"]
        if period < p["command_period"] * 0.999:
            raise FicInputError(f"control_rate {p['control_rate']:g} Hz is faster than the joint states "
                                f"(command_period {p['command_period']:g} s)")
        optimisation = PosturalOptimisation(self._limits, period, velocity_horizon=p["velocity_horizon"])
        return ReplicaController(robot, controller, self._limits, posture, period, optimisation,
                                 joint_damping_compensation=bool(p["joint_damping_compensation"]),
                                 # The feedforward never pushes harder than the FIC may (fic_core.replica).
                                 feedforward_limit=(p["translation_max_force"], p["rotation_max_force"]))

    def _set_point_hold(self) -> SampledSetPoint:
        return SampledSetPoint(3, self._p["set_point_acceleration_filter"], self._p["set_point_extrapolation"],
                               SET_POINT_MAX_GAP_S)

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        overrides = {parameter.name: parameter.value for parameter in parameters}
        try:
            p = self._parameter_values(overrides)
            replica = self._build_replica(p)
        except (FicInputError, TypeError, ValueError) as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        if self._replica.previous_torque is not None:  # keep the torque-rate bound across the swap
            replica.reset(previous_torque=self._replica.previous_torque)
            replica.ticks, replica.shaped_ticks = self._replica.ticks, self._replica.shaped_ticks
            replica.violation_ticks = self._replica.violation_ticks
        self._replica = replica
        if p["diagnostics_rate"] != self._p["diagnostics_rate"]:
            self._diagnostics_timer.cancel()
            self._diagnostics_timer = self.create_timer(1.0 / p["diagnostics_rate"], self._publish_diagnostics)
        for hold in (self._planner_hold, self._offset_hold):
            hold.acceleration_time_constant = p["set_point_acceleration_filter"]
            hold.max_extrapolation = p["set_point_extrapolation"]
        self._p = p
        self.get_logger().info(f"parameters changed: {', '.join(f'{k}={v}' for k, v in overrides.items())}")
        return SetParametersResult(successful=True)

    # --- inputs ----------------------------------------------------------------------------------------------
    def _refuse(self, what: str, reason: str, counter: str) -> None:
        self._counts[counter] += 1
        self.get_logger().error(f"refusing {what}: {reason}; keeping the last good value",
                                throttle_duration_sec=LOG_THROTTLE_S)

    def _on_teleop_command(self, message: TeleoperationCommand) -> None:
        offset = message.desired_offset
        if not _finite(offset.x, offset.y, offset.z):
            self._refuse("/replica/teleop_command", f"desired_offset is not finite ({offset.x}, {offset.y}, "
                         f"{offset.z})", "rejected_teleop_commands")
            return
        self._counts["teleop_commands"] += 1
        self._commanded_offset = np.array([offset.x, offset.y, offset.z])
        self._master_stamp = message.header.stamp
        first = self._master_received is None
        self._master_received = self._now()
        self._offset_hold.add(_seconds(message.header.stamp), self._commanded_offset, self._master_received)
        if self._master_stale or first:  # the first command is approached the same way: no jump either
            if self._master_stale:
                self.get_logger().warning(f"teleoperation commands are back: moving x_d' to the new command at "
                                          f"<= {self._p['resume_speed']:g} m/s")
            self._master_stale = False
            self._offset_jump.start(self._offset, self._commanded_offset, self._p["resume_speed"])

    def _on_planner_pose(self, message: PoseStamped) -> None:
        position, orientation = message.pose.position, message.pose.orientation
        if not _finite(position.x, position.y, position.z, orientation.x, orientation.y, orientation.z,
                       orientation.w):
            self._refuse("/planner/desired_pose", "the pose is not finite", "rejected_planner_poses")
            return
        try:
            rotation = rotation_from_quaternion([orientation.x, orientation.y, orientation.z, orientation.w])
        except FicInputError as exc:
            self._refuse("/planner/desired_pose", str(exc), "rejected_planner_poses")
            return
        self._counts["planner_poses"] += 1
        self._planner_position = np.array([position.x, position.y, position.z])
        self._planner_rotation = rotation
        self._planner_hold.add(_seconds(message.header.stamp), self._planner_position, self._now())


    def _on_planner_accel(self, message: AccelStamped) -> None:
        linear = message.accel.linear
        if not _finite(linear.x, linear.y, linear.z):
            self._refuse("/planner/desired_accel", "the acceleration is not finite", "rejected_planner_poses")
            return
        self._planner_acceleration = np.array([linear.x, linear.y, linear.z])
        self._planner_acceleration_received = self._now()

    def _feedforward_acceleration(self) -> np.ndarray | None:
        """The acceleration of x_d = x_d'' + x_d' for the inertial feedforward (beyond paper Eq. 7,
        fic_core.replica): the planner's own (fresh values only), plus the estimate for the teleoperated offset x_d', from the stamps of the
        teleoperation commands while they are not stale. The jumps being given back (ShrinkingOffset) move at
        constant speed: no acceleration."""
        now = self._now()
        acceleration = None
        if self._p["planner_feedforward"] and self._planner_acceleration is not None and \
                self._planner_in_use is not None and \
                now - self._planner_acceleration_received <= FEEDFORWARD_TIMEOUT_S:
            acceleration = self._planner_acceleration
        if self._p["offset_feedforward"] and not self._master_stale and self._offset_hold.has_sample:
            offset_acceleration = self._offset_hold.acceleration(now)
            acceleration = offset_acceleration if acceleration is None else acceleration + offset_acceleration
        return acceleration

    def _on_wrench(self, message: WrenchStamped) -> None:
        force, torque = message.wrench.force, message.wrench.torque
        if not _finite(force.x, force.y, force.z, torque.x, torque.y, torque.z):
            self._refuse("/ft_sensor/wrench", "the wrench is not finite", "rejected_wrenches")
            return
        self._counts["wrenches"] += 1
        self._wrench.header.stamp = message.header.stamp
        self._wrench.wrench = message.wrench

    def _joint_order(self, names: list[str]) -> np.ndarray | None:
        key = tuple(names)
        index = self._index_cache.get(key)
        if index is None:
            try:
                index = np.array([names.index(name) for name in ARM_JOINT_NAMES])
            except ValueError:
                return None
            self._index_cache[key] = index
        return index

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # --- the control step ------------------------------------------------------------------------------------
    def _on_joint_state_bytes(self, data: bytes) -> None:
        """The joint state as CDR bytes: its header stamp (right after the 4-byte encapsulation) tells whether it
        is a control tick; the others are counted and skipped without building the message (a JointState costs
        tens of microseconds to convert, and in realtime most states are not control ticks)."""
        if not self._p["answer_every_state"] and self._last_control_time is not None and len(data) >= 12:
            sec, nanosec = (STAMP_LITTLE_ENDIAN if data[1] == 1 else STAMP_BIG_ENDIAN).unpack_from(data, 4)
            if not self._control_due(sec + 1e-9 * nanosec) and not self._command_waiting():
                self._counts["joint_states"] += 1
                return
        self._on_joint_state(deserialize_message(data, JointState))

    def _command_waiting(self) -> bool:
        """Whether a teleoperation command has arrived that no control tick has used yet (tick_on_command)."""
        return self._p["tick_on_command"] and self._master_received is not None and \
            self._master_stamp != self._master_stamp_used

    def _control_due(self, time: float) -> bool:
        """Whether the joint state stamped ``time`` starts a control tick (half a command period of slack)."""
        last = self._last_control_time
        return last is None or time < last or \
            time - last >= 1.0 / self._p["control_rate"] - 0.5 * self._p["command_period"]

    def _on_joint_state(self, message: JointState) -> None:
        self._counts["joint_states"] += 1
        index = self._joint_order(list(message.name))
        if index is None or len(message.position) != len(message.name) or len(message.velocity) != len(message.name):
            self._refuse("/joint_states", f"expected positions and velocities of {', '.join(ARM_JOINT_NAMES)}, got "
                         f"names {list(message.name)}", "rejected_joint_states")
            self._publish_torque(None, None)
            return
        q = np.asarray(message.position)[index]
        qd = np.asarray(message.velocity)[index]
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
            self._refuse("/joint_states", "positions or velocities are not finite", "rejected_joint_states")
            self._publish_torque(None, None)
            return
        stamp = message.header.stamp
        time = _seconds(stamp)
        if not self._started:
            self._robot.update(q, qd)
            self._start_position = self._robot.tcp_position.copy()
            self._start_rotation = self._robot.tcp_rotation.copy()
            self._started = True
            self.get_logger().info(f"first joint state: holding the TCP at {np.round(self._start_position, 4)} "
                                   "until the master and the planner speak")

        control_period = 1.0 / self._p["control_rate"]
        due = self._control_due(time) or self._command_waiting()
        if due:
            # The time since the last control tick, by the joint-state stamps: a busy replica skips states, and
            # x_d's velocity (the FIC's error rate, the friction feedforward) and the give-back of jumps must use
            # the real interval, not the nominal one (a skipped tick at the nominal dt doubled the velocity).
            last = self._last_control_time
            dt = time - last if last is not None and 0.0 < time - last <= MAX_CONTROL_INTERVAL_S else control_period
            self._last_control_time = time
            self._control(q, qd, stamp, max(dt, 0.5 * control_period))
        if due or self._p["answer_every_state"]:
            self._publish_torque(self._held_torque, time)
        if self._due(self._last_pose_time, time, self._p["pose_rate"]):
            self._last_pose_time = time
            self._publish_poses(stamp)
        if self._last_command is not None and self._due(self._last_status_time, time, self._p["status_rate"]):
            self._last_status_time = time
            self._publish_status(self._last_command, stamp)

    def _due(self, last: float | None, time: float, rate: float) -> bool:
        """Whether a stream at ``rate`` is due at joint-state time ``time`` (half a command period of slack)."""
        return last is None or time < last or time - last >= 1.0 / rate - 0.5 * self._p["command_period"]

    def _update_planner(self, dt: float) -> np.ndarray:
        """x_d'' in use: the start TCP pose until the planner speaks; then the planner's output held between
        samples (first-order hold), with the jump from the start pose to its first pose given back at
        resume_speed (the planner may start elsewhere; fic_core.set_point.ShrinkingOffset)."""
        if self._planner_position is None:
            return self._start_position
        planner = self._planner_hold.position(self._now())
        if self._planner_in_use is None:  # the first planner pose: start from the start pose
            self._planner_jump.start(self._start_position, planner, self._p["resume_speed"])
        self._planner_in_use = self._planner_jump.apply(planner, dt)
        return self._planner_in_use

    def _update_offset(self, dt: float) -> None:
        """x_d' in use: the commanded one, held while stale, rate-limited back after a stale period."""
        if self._master_received is not None and not self._master_stale and \
                self._now() - self._master_received > self._p["master_timeout"]:
            self._master_stale = True
            self._offset_jump.stop()
            self.get_logger().warning(
                f"no teleoperation command for more than master_timeout = {self._p['master_timeout']:g} s: holding "
                f"the last desired offset {np.round(self._offset, 4)} (the replica stays under its FIC)")
        if self._master_stale:
            return
        commanded = self._offset_hold.position(self._now()) if self._offset_hold.has_sample else self._commanded_offset
        self._offset = self._offset_jump.apply(commanded, dt)

    def _control(self, q: np.ndarray, qd: np.ndarray, stamp: Time, dt: float) -> None:
        self._update_offset(dt)
        desired_position = self._update_planner(dt) + self._offset  # x_d = x_d'' + x_d'
        use_planner_rotation = self._p["use_planner_orientation"] and self._planner_rotation is not None
        desired_rotation = self._planner_rotation if use_planner_rotation else self._start_rotation
        desired_twist = self._desired_twist(desired_position, dt)
        try:
            command = self._replica.command(q, qd, desired_position, desired_rotation, desired_twist,
                                            desired_acceleration=self._feedforward_acceleration())
        except FicInputError as exc:  # only reachable through a bug upstream: hold, say why
            self._counts["controller_errors"] += 1
            self.get_logger().error(f"control step refused its inputs: {exc}; holding",
                                    throttle_duration_sec=LOG_THROTTLE_S)
            command = self._replica.hold(q, qd)
        self._counts["control_ticks"] += 1
        self._last_command = command
        self._held_torque = command.torque
        self._shaping_since_status |= int(command.limit_shaping)
        self._violations_since_status |= int(command.limit_violations)
        if self._master_received is not None and self._master_stamp != self._master_stamp_used:
            # First use of this teleop command: its age now is the pipeline latency plus the channel's hold
            # (SPEC 2.2), kept with it so that a FicState published at a lower rate still carries it exactly.
            self._master_stamp_used = self._master_stamp
            self._master_first_use_age = self._now() - _seconds(self._master_stamp)

    def _desired_twist(self, desired_position: np.ndarray, dt: float) -> np.ndarray | None:
        """x_d's velocity, low-pass filtered (x_d moves in steps as messages arrive), so that the FIC's error rate
        is desired minus measured TCP velocity."""
        time_constant = self._p["desired_velocity_filter"]
        previous = self._previous_desired
        self._previous_desired = desired_position
        if time_constant <= 0.0 or previous is None:
            return None
        raw = (desired_position - previous) / dt
        self._desired_velocity = self._desired_velocity + (raw - self._desired_velocity) * (dt / (time_constant + dt))
        return np.concatenate((self._desired_velocity, np.zeros(3)))

    # --- outputs ---------------------------------------------------------------------------------------------
    def _publish_torque(self, target: np.ndarray | None, time: float | None) -> None:
        """Publish the held torque, slewed at the torque-rate limit over the time since the last command (at least
        one command period; never a faster step). ``time``: the joint-state time it answers (None: unknown)."""
        if target is None:
            target = self._published_torque
            if target is None:
                return
        previous = self._published_torque
        if previous is not None:
            elapsed = self._p["command_period"]
            if time is not None and self._published_time is not None and time > self._published_time:
                elapsed = max(elapsed, time - self._published_time)
            step = self._limits.torque_rate * elapsed
            target = previous + np.clip(target - previous, -step, step)
        self._published_torque = target
        if time is not None:
            self._published_time = time
        self._command_pub.publish(Float64MultiArray(data=target.tolist()))

    def _publish_status(self, command, stamp: Time) -> None:
        # FicState is stamped when it is published (the node clock); the pipeline latency (SPEC 2.2: master sample
        # -> the command that first used it, including any wait in the replica's queue) is master_age, taken at
        # that first use. The joint state it answers carries the sensor stamp (LimitStatus, poses).
        computed = self.get_clock().now().to_msg()
        state = FicState()
        state.header.stamp = computed
        state.header.frame_id = BASE_FRAME
        state.controller = command.controller_name
        state.phase = [int(x) for x in command.phase]
        state.error = np.concatenate((command.tracking_error, command.rotation_error)).tolist()
        state.latched_max_error = command.latched_max_error.tolist()
        state.force = command.wrench.tolist()
        state.stored_energy = command.stored_energy.tolist()
        state.total_energy = float(command.total_energy)
        state.master_stamp = self._master_stamp_used
        state.master_age = self._master_first_use_age
        state.master_stale = self._master_stale
        self._fic_state_pub.publish(state)

        status = LimitStatus()
        status.header.stamp = stamp
        status.header.frame_id = BASE_FRAME
        status.shaping = self._shaping_since_status
        status.violations = self._violations_since_status
        self._shaping_since_status = self._violations_since_status = 0
        status.torque_change = float(command.torque_change)
        status.torque_ratio = command.torque_ratio.tolist()
        status.torque_rate_ratio = command.torque_rate_ratio.tolist()
        status.joint_velocity_ratio = command.joint_velocity_ratio.tolist()
        status.joint_position_margin = command.joint_position_margin.tolist()
        status.tcp_speed = float(command.tcp_speed)
        status.ticks = self._replica.ticks
        status.shaped_ticks = self._replica.shaped_ticks
        status.violation_ticks = self._replica.violation_ticks
        self._limit_status_pub.publish(status)

    def _publish_poses(self, stamp: Time) -> None:
        command = self._last_command
        if command is None:
            return
        for publisher, position, rotation in (
                (self._desired_pose_pub, command.desired_position, command.desired_rotation),
                (self._tcp_pose_pub, command.tcp_position, command.tcp_rotation)):
            pose = PoseStamped()
            pose.header.stamp = stamp
            pose.header.frame_id = BASE_FRAME
            pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = position.tolist()
            x, y, z, w = pin.Quaternion(rotation).coeffs().tolist()
            pose.pose.orientation.x, pose.pose.orientation.y, pose.pose.orientation.z = x, y, z
            pose.pose.orientation.w = w
            publisher.publish(pose)
        if self._wrench.header.stamp.sec or self._wrench.header.stamp.nanosec:
            self._feedback_pub.publish(self._wrench)  # F_R: the F/T reading, with the sensor's stamp

    def statistics(self) -> dict[str, str]:
        optimisation = self._replica.optimisation
        values = {key: str(value) for key, value in self._counts.items()}
        values.update({
            "controller": self._p["controller"],
            "master_watchdog": "stale (holding x_d')" if self._master_stale else
            ("no command yet" if self._master_received is None else ("resuming" if self._offset_jump.active else "ok")),
            "planner": "no pose yet (holding the start pose)" if self._planner_position is None else "ok",
            "ticks": str(self._replica.ticks),
            "shaped_ticks": str(self._replica.shaped_ticks),
            "violation_ticks": str(self._replica.violation_ticks),
            "qp_solves": str(optimisation.qp_count),
            "relaxed_solves": str(optimisation.relaxed_count),
            "guard_clips": str(optimisation.guard_clips),
        })
        return values

    def _publish_diagnostics(self) -> None:
        status = DiagnosticStatus(name="replica", hardware_id="fic_teleop_replica")
        if self._master_stale or self._replica.violation_ticks:
            status.level = DiagnosticStatus.WARN
            status.message = "master stale: holding x_d'" if self._master_stale else "limit violations seen"
        else:
            status.level = DiagnosticStatus.OK
            status.message = "running" if self._started else "waiting for /joint_states"
        status.values = [KeyValue(key=key, value=value) for key, value in self.statistics().items()]
        array = DiagnosticArray()
        array.header.stamp = self.get_clock().now().to_msg()
        array.status = [status]
        self._diagnostics_pub.publish(array)


def main(args: list[str] | None = None) -> None:
    try:
        rclpy.init(args=args)
    except RCLError as exc:  # e.g. a malformed --params-file: refuse to start, in one clear line
        rclpy.logging.get_logger(NODE_NAME).fatal(f"cannot start: bad ROS arguments or parameter file: {exc}")
        raise SystemExit(2) from None
    node = None
    try:
        node = ReplicaNode()
        # EventsExecutor spun in spin_once slices: its spin() from these rclpy 7.1 wheels busy-waits and never
        # returns on SIGINT/SIGTERM, but spin_once is cheap (measured here with 1 kHz joint states and 250 Hz
        # poses: 11 % of a core and 93 % of messages taken, against 28 % and 79 % for SingleThreadedExecutor).
        # Under simulated time (lockstep) the EventsExecutor's timers do not follow /clock (measured on the
        # master: bursts of ticks with one stamp, then silences); the wait-set executor checks them against it.
        executor = SingleThreadedExecutor() if node.get_parameter("use_sim_time").value else EventsExecutor()
        executor.add_node(node)
        # The start-up heap (rclpy, numpy, Pinocchio, MuJoCo: ~60k objects) moved out of the collector's reach: a
        # full collection of it took 25 ms here, and with it every loop in the graph stalled every few seconds.
        gc.collect()
        gc.freeze()
        # A slice runs every callback due in it inside the executor, not one per Python call: a 1 kHz timer cost
        # 77-82 us a tick here against 92-101 us with spin_once (the future never completes; the slice bounds the wait).
        never = Future()
        while rclpy.ok():  # short slices so that the signal handler's shutdown is seen promptly
            try:
                executor.spin_until_future_complete(never, timeout_sec=0.1)
            except (KeyboardInterrupt, ExternalShutdownException):
                break
            except Exception:
                # Seen once in 4 long runs: the EventsExecutor of these wheels raised a pybind11 conversion error
                # from a callback racing the context's shutdown. Only then is it not an error of ours.
                if rclpy.ok():
                    raise
                break
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (FicInputError, ParameterException) as exc:  # out-of-range, NaN or wrongly typed parameters
        rclpy.logging.get_logger(NODE_NAME).fatal(f"cannot start: {exc}")
        raise SystemExit(2) from None
    finally:
        if node is not None:
            node.get_logger().info(f"replica stopped: {node.statistics()}")
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
