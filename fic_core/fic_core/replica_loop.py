"""The replica's loop, one joint state at a time: what the replica node runs and the in-process runner steps.

    joint state (q, qd at time t) --> ControlSchedule: a control tick?
        tick:     DesiredPose x_d = x_d'' + x_d' --> DesiredVelocityFilter --> ReplicaController (paper Eq. 7,
                  the postural optimisation, the torque slew) --> the torque to send
        between:  the held torque, slewed (only if every state is answered, as lockstep needs)
    teleoperation command --> CommandAuthority (fic_core.input_authority) --> x_d' --> DesiredPose
    planner pose (x_d'') --> SetPointAuthority (the same workspace and speed bounds) --> DesiredPose
    planner acceleration --> DesiredPose

Two clocks, as on the robot: ``time`` is the joint state's stamp (the control grid, the slew, the status rates),
``now`` the receiver's clock (the set-point holds, the watchdog); in lockstep both are simulated time. Before the
first joint state nothing is sent; a joint state that cannot be used repeats the last torque sent. Inputs with
NaN/Inf raise FicInputError and leave every value as it was (the caller logs them once, throttled).
What the caller should say (a watchdog turning stale, commands back) comes back as ``notices``.

The loop watches itself (fic_core.loop_health): at every control tick the state's age and the gap since the last
tick are checked against loop_max_state_age and loop_max_tick_gap; beyond them the tick sends the stated hold
(gravity and joint damping, as the robot's own watchdog; on a stale state gravity once, then nothing, so that the
robot's own watchdog holds the arm on its own state) instead of the law, until loop_resume_ticks healthy ticks
in a row; the law then starts afresh (the task controller's phases and latches reset, the slew from the hold
torque, x_d from the arm's TCP with the set-points' progress during the hold given back at resume_speed) and is
blended in over loop_resume_ramp. Inside the bounds a late tick (the states more than 1.5 control periods apart)
tells the FIC how long its last torque was held, and it adds the damper that gives back what its springs lost to
that sample-and-hold (fic_core.sampled_spring_damping).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .control_schedule import ControlSchedule, RateGate
from .desired_pose import DesiredPose, DesiredPoseParameters
from .desired_velocity import DesiredVelocityFilter
from .errors import FicInputError, finite_array
from .input_authority import CommandAuthority, CommandVerdict, SetPointAuthority
from .limits import PandaLimits
from .loop_health import LoopHealth, LoopHealthBounds
from .passivity_observer import PassivityObserver
from .quaternion import rotation_from_quaternion
from .replica import ReplicaCommand, ReplicaController
from .replica_parameters import ReplicaLoopParameters, build_replica_controller, checked
from .robot_model import RobotModel
from .sampled_spring_damping import late_hold

COUNTERS = ("joint_states", "control_ticks", "teleop_commands", "planner_poses", "wrenches", "rejected_joint_states",
            "rejected_teleop_commands", "rejected_planner_poses", "rejected_wrenches", "controller_errors")


@dataclass
class ReplicaStep:
    """What one joint state produced."""

    torque: NDArray[np.float64] | None = None     # the torque to send now (None: send nothing)
    command: ReplicaCommand | None = None         # the control tick's report (None: no tick)
    poses_due: bool = False                       # desired/TCP poses and F_R are due (pose_rate)
    status_due: bool = False                      # FicState and LimitStatus are due (status_rate)
    notices: list[tuple[str, str]] = field(default_factory=list)  # (level, text): info, warning, error
    held: bool = False                            # the torque is the loop's hold, not the law (loop_health)


def _loop_health_bounds(p: ReplicaLoopParameters) -> LoopHealthBounds:
    return LoopHealthBounds(p.loop_max_state_age, p.loop_max_tick_gap, int(p.loop_resume_ticks), p.loop_resume_ramp)


def _desired_pose_parameters(p: ReplicaLoopParameters) -> DesiredPoseParameters:
    return DesiredPoseParameters(p.master_timeout, p.resume_speed, p.set_point_acceleration_filter,
                                 p.set_point_extrapolation, p.planner_feedforward, p.offset_feedforward,
                                 p.use_planner_orientation, p.interpolate_link_samples,
                                 p.offset_feedforward_contact_gate, p.offset_feedforward_contact_force,
                                 p.offset_feedforward_settle)


class ReplicaLoop:
    """The replica's control logic for its parameters (fic_core.replica_parameters; module docstring).
    ``parameters`` is kept as the loop runs them now (``configure`` replaces it)."""

    def __init__(self, parameters: ReplicaLoopParameters, robot: RobotModel | None = None,
                 limits: PandaLimits | None = None, authority: CommandAuthority | None = None) -> None:
        self.robot = RobotModel() if robot is None else robot
        #: What a teleoperation command may ask (fic_core.input_authority; None: its documented default bounds).
        self.authority = CommandAuthority() if authority is None else authority
        #: The same bounds on the planner's x_d'' (workspace about the start pose, speed), from the first state on.
        self.planner_authority = SetPointAuthority(self.authority.bounds)
        self._pending_planner_pose: tuple[int, NDArray[np.float64], NDArray[np.float64], float] | None = None
        self._planner_quaternion: tuple | None = None   # the last planner orientation and its rotation matrix
        self._planner_rotation = np.eye(3)
        # The arm's datasheet limits (fic_core.arm_profile: Panda by default, an FR3 behind franka_ros2).
        self.limits = PandaLimits.from_robot(self.robot) if limits is None else limits
        p = self.parameters = checked(parameters)
        self.controller: ReplicaController = build_replica_controller(self.robot, self.limits, p)
        self.desired = DesiredPose(_desired_pose_parameters(p))
        self.velocity_filter = DesiredVelocityFilter(p.desired_velocity_filter)
        self.schedule = ControlSchedule(p.control_rate, p.command_period, p.tick_on_command)
        self._pose_gate = RateGate(p.pose_rate, p.command_period)
        self._status_gate = RateGate(p.status_rate, p.command_period)
        self.last_command: ReplicaCommand | None = None
        #: Port work and storage of the task-space controller, every control tick (fic_core.passivity_observer).
        self.passivity = PassivityObserver(6)
        self._shaping_since_status = 0      # LimitStatus flags OR-ed over the ticks since the last message
        self._violations_since_status = 0
        self.counts = {name: 0 for name in COUNTERS}
        #: The loop's own health: state age, tick and command gaps, the hold (fic_core.loop_health).
        self.health = LoopHealth(_loop_health_bounds(p))
        self._hold_torque: NDArray[np.float64] | None = None   # the last hold torque sent

    # --- parameters ------------------------------------------------------------------------------------------
    def configure(self, changes: Mapping[str, Any]) -> ReplicaLoopParameters:
        """Change parameters at run time (names of the loop's rows): all or none (FicInputError names the bad
        one, or a name no row has and the nearest). The new controller takes over the torque sent, the counters
        and the control grid; returns the parameters now in force."""
        p = checked(self.parameters.replaced(changes))
        controller = build_replica_controller(self.robot, self.limits, p)
        schedule = ControlSchedule(p.control_rate, p.command_period, p.tick_on_command)
        desired = _desired_pose_parameters(p)
        controller.continue_from(self.controller)
        schedule.continue_from(self.schedule)
        self.controller, self.schedule = controller, schedule
        self.passivity.restart_port()  # a new controller, a new storage
        self.desired.parameters = desired
        self.health.bounds = _loop_health_bounds(p)
        self.velocity_filter.time_constant = p.desired_velocity_filter
        for gate, rate in ((self._pose_gate, p.pose_rate), (self._status_gate, p.status_rate)):
            gate.rate, gate.command_period = rate, p.command_period
        self.parameters = p
        return p

    # --- inputs ----------------------------------------------------------------------------------------------
    def _counted(self, counter: str, call, *args):
        try:
            result = call(*args)
        except FicInputError:
            self.counts["rejected_" + counter] += 1
            raise
        self.counts[counter] += 1
        return result

    def add_teleoperation(self, stamp_ns: int, offset: ArrayLike, now: float) -> str | None:
        """x_d' of a teleoperation command; a notice when commands are back after a stale period."""
        return self._counted("teleop_commands", self.desired.add_teleoperation, stamp_ns, offset, now)

    def teleoperation_command(self, stamp_ns: int, now: float, *, mode: int, haptic_gain: float,
                              workspace_scale: float, velocity_gain: float, handle_position: ArrayLike,
                              desired_offset: ArrayLike) -> tuple[CommandVerdict, str | None]:
        """A whole teleoperation command: the authority's verdict on it and, if accepted, its (bounded) x_d'
        taken in. Returns the verdict and add_teleoperation's notice. FicInputError as add_teleoperation.

        On the first command after a loss (the master watchdog stale) the authority forgets the last command
        first: the jump from the held x_d' is DesiredPose's to give back at resume_speed (0.1 m/s, slower than
        the authority's max_offset_speed), and the rate bound measured against a command from before the loss
        would take it out a second time."""
        if self.desired.master_stale:
            self.authority.reset()
        verdict = self.authority.check(stamp=stamp_ns * 1e-9, now=now, mode=mode, haptic_gain=haptic_gain,
                                       workspace_scale=workspace_scale, velocity_gain=velocity_gain,
                                       handle_position=handle_position, desired_offset=desired_offset)
        if not verdict.accepted:
            self.counts["rejected_teleop_commands"] += 1
            return verdict, None
        return verdict, self.add_teleoperation(stamp_ns, verdict.offset, now)

    def add_planner_pose(self, stamp_ns: int, position: ArrayLike, quaternion_xyzw: ArrayLike, now: float) -> None:
        """x_d'' of the planner (orientation as a quaternion x, y, z, w), bounded by the planner authority (the
        workspace about the start pose, the speed). Before the first joint state the newest pose waits for it."""
        def add() -> None:
            # The planner's orientation rarely changes between its poses: the last one's rotation is reused for the
            # same four numbers (a NaN never equals itself, so a bad one is always checked and refused).
            try:
                key: tuple | None = tuple(quaternion_xyzw)
            except TypeError:   # not a sequence: rotation_from_quaternion says why
                key = None
            if key is not None and key == self._planner_quaternion:
                rotation = self._planner_rotation.copy()
            else:
                rotation = rotation_from_quaternion(quaternion_xyzw)
                self._planner_quaternion, self._planner_rotation = key, rotation.copy()
            target = finite_array("planner_position", position, (3,))
            if not self.desired.started:
                self._pending_planner_pose = (stamp_ns, target, rotation, now)
                return
            self.desired.add_planner_pose(stamp_ns, self.planner_authority.check(target, now), rotation, now)
        self._counted("planner_poses", add)

    def measure_contact_force(self, force_norm: float) -> None:
        """|F_R| [N] as measured (inf: a reading refused): after a contact the offset feedforward waits out its echo
        (fic_core.offset_feedforward_gate)."""
        self.desired.measure_contact_force(force_norm)

    def add_planner_acceleration(self, acceleration: ArrayLike, now: float) -> None:
        try:
            self.desired.add_planner_acceleration(acceleration, now)
        except FicInputError:
            self.counts["rejected_planner_poses"] += 1
            raise

    # --- the control step ------------------------------------------------------------------------------------
    def skips(self, time: float) -> bool:
        """Whether a joint state stamped ``time`` can be counted and dropped unread (no tick, no answer)."""
        return not self.parameters.answer_every_state and self.schedule.last_tick is not None and \
            not self.schedule.due(time, self.desired.command_unused)

    def skip(self) -> None:
        self.counts["joint_states"] += 1

    def refuse_joint_state(self) -> NDArray[np.float64] | None:
        """A joint state that cannot be used: the last torque sent, again (None before any)."""
        self.counts["joint_states"] += 1
        self.counts["rejected_joint_states"] += 1
        if self.health.holding:
            return None if self._hold_torque is None else self._hold_torque.copy()
        return self.controller.repeat_torque()

    def joint_state(self, time: float, now: float, q: NDArray[np.float64], qd: NDArray[np.float64]) -> ReplicaStep:
        """One joint state (validated q, qd at joint-state time ``time``, received at ``now``)."""
        self.counts["joint_states"] += 1
        step = ReplicaStep()
        if not self.desired.started:
            self.robot.update(q, qd)
            self.desired.start(self.robot.tcp_position, self.robot.tcp_rotation)
            self.planner_authority.start(self.robot.tcp_position)
            if self._pending_planner_pose is not None:
                stamp_ns, target, rotation, received = self._pending_planner_pose
                self.desired.add_planner_pose(stamp_ns, self.planner_authority.check(target, received), rotation,
                                              received)
                self._pending_planner_pose = None
            step.notices.append(("info", f"first joint state: holding the TCP at "
                                         f"{np.round(self.desired.start_position, 4)} until the master and the "
                                         "planner speak"))
        health = self.health
        if self.schedule.due(time, self.desired.command_unused):
            dt = self.schedule.tick(time)
            notice = health.tick(now, time)
            if notice:
                step.notices.append(("warning" if health.holding else "info", notice))
            if health.holding:
                step.torque, step.held = self._hold(q, qd, now, dt, step.notices), True
            else:
                step.command = self._resume_or_control(q, qd, time, now, dt, step.notices)
                step.torque = step.command.torque
        elif self.parameters.answer_every_state:
            if health.holding:
                step.torque, step.held = (None if self._hold_torque is None else self._hold_torque.copy()), True
            else:
                step.torque = self.controller.held_torque(time)
        if step.torque is not None:
            health.command_sent(now)
        # While holding there is no law's tick to report: its poses and status wait for the law.
        step.poses_due = not step.held and self._pose_gate.take(time)
        step.status_due = not step.held and self.last_command is not None and self._status_gate.take(time)
        return step

    def ready(self, step: ReplicaStep, time: float, now: float) -> ReplicaStep:
        """Before ``step``'s torque goes out at ``now`` (the state of ``time``): a law torque whose state has grown
        older than loop_max_state_age while it was computed is not sent; the loop holds, and the hold's gravity
        (the state's velocity is old) goes out in its place (fic_core.loop_health)."""
        if step.torque is None or step.held:
            return step
        notice = self.health.ready(now, time)
        if notice:
            step.notices.append(("warning", notice))
            step.torque = self.health.hold_command(self.robot.gravity, self.robot.qd)
            step.held = True
            self._hold_torque = step.torque
            step.poses_due = step.status_due = False
        return step

    def _hold(self, q: NDArray[np.float64], qd: NDArray[np.float64], now: float, dt: float,
              notices: list[tuple[str, str]]) -> NDArray[np.float64] | None:
        """A control tick of the loop's hold: G(q) and joint damping (loop_health.hold_command; None: nothing to
        send, the robot's watchdog holds). x_d keeps moving meanwhile (the set-points' own holds and give-backs run
        on), so the law comes back to today's target."""
        sample = self.desired.update(now, dt)
        notices.extend(("warning", text) for text in sample.notices)
        self.velocity_filter.update(sample.position, dt)
        self.robot.update(q, qd)
        torque = self.health.hold_command(self.robot.gravity, qd)
        self.health.held_tick()
        if torque is None:
            return None
        self._hold_torque = torque
        return torque.copy()

    def _resume_or_control(self, q: NDArray[np.float64], qd: NDArray[np.float64], time: float, now: float,
                           dt: float, notices: list[tuple[str, str]]) -> ReplicaCommand:
        """The law's tick; on the way back from a hold, started afresh from the hold torque and blended in."""
        health = self.health
        if health.resumed_at_this_tick(now):
            # x_d moved on during the hold: the law starts at the arm's TCP, the rest given back at resume_speed
            # (fic_core.desired_pose), never onto the error the hold left.
            self.robot.update(q, qd)
            self.desired.anchor(self.robot.tcp_position)
            self.velocity_filter.reset()   # x_d's step onto the TCP is no velocity of the set-points
            if self._hold_torque is not None:
                # The controller's phases and latched errors belong to the states before the hold; the slew starts
                # from the torque the arm has now.
                self.controller.reset(self._hold_torque)
        command = self._control(q, qd, time, now, dt, notices)
        fraction = health.law_fraction(now)
        if fraction < 1.0:
            hold = health.hold_torque(self.robot.gravity, qd, health.state_fresh)
            torque = hold + fraction * (command.torque - hold)
            self.controller.state_sent(torque, time)
            command.torque = torque
        return command

    def _control(self, q: NDArray[np.float64], qd: NDArray[np.float64], time: float, now: float, dt: float,
                 notices: list[tuple[str, str]]) -> ReplicaCommand:
        sample = self.desired.update(now, dt)
        notices.extend(("warning", text) for text in sample.notices)
        desired_twist = self.velocity_filter.update(sample.position, dt)
        # The last torque was held dt (the states' interval): on a late tick the FIC gives back what its springs
        # lose to that sample-and-hold (fic_core.sampled_spring_damping), up to the loop's own bound.
        self.controller.late_tick(late_hold(dt, self.schedule.control_period, self.health.bounds.max_tick_gap))
        try:
            command = self.controller.command(q, qd, sample.position, sample.rotation, desired_twist,
                                              desired_acceleration=sample.acceleration, time=time)
        except FicInputError as exc:  # only reachable through a bug upstream: hold, say why
            self.counts["controller_errors"] += 1
            notices.append(("error", f"control step refused its inputs: {exc}; holding"))
            command = self.controller.hold(q, qd, time=time)
        self.counts["control_ticks"] += 1
        snapshot = command.controller_snapshot
        if hasattr(snapshot, "port_values"):
            self.passivity.observe_snapshot(snapshot)
        self.last_command = command
        self._shaping_since_status |= int(command.limit_shaping)
        self._violations_since_status |= int(command.limit_violations)
        return command

    def take_limit_flags(self) -> tuple[int, int]:
        """(shaping, violations) OR-ed over the ticks since the last call (a LimitStatus message each)."""
        flags = (self._shaping_since_status, self._violations_since_status)
        self._shaping_since_status = self._violations_since_status = 0
        return flags

    # --- reports ---------------------------------------------------------------------------------------------
    def watchdog_state(self) -> str:
        desired = self.desired
        if desired.master_stale:
            return "stale (holding x_d')"
        if desired.master_received is None:
            return "no command yet"
        return "resuming" if desired.resuming else "ok"

    def statistics(self) -> dict[str, str]:
        controller = self.controller
        optimisation = controller.optimisation
        values = {key: str(value) for key, value in self.counts.items()}
        values.update({
            "controller": self.parameters.controller,
            "master_watchdog": self.watchdog_state(),
            "planner": "ok" if self.desired.has_planner else "no pose yet (holding the start pose)",
            "ticks": str(controller.ticks),
            "shaped_ticks": str(controller.shaped_ticks),
            "violation_ticks": str(controller.violation_ticks),
            "passivity_margin_min_j": f"{self.passivity.min_margin:.3g}",
            "passivity_violation_ticks": str(self.passivity.violation_ticks),
            "qp_solves": str(optimisation.qp_count),
            "relaxed_solves": str(optimisation.relaxed_count),
            "guard_clips": str(optimisation.guard_clips),
            "clamped_planner_poses": str(self.planner_authority.clamped),
            "rate_limited_planner_poses": str(self.planner_authority.rate_limited),
            "loop_health": self.health.state,
            "loop_holds": str(self.health.holds),
        })
        return values
