"""The replica side's logic around fic_core.ReplicaLoop (paper Eq. 7 and the postural optimisation): what the replica
node runs and the in-process runner steps, beside fic_core.master_station on the operator's side.

    who writes each stream (the node's graph lookups, as names or counts) --> RobotStreamGuard: a second writer of a
        robot stream (joint states, torque commands, the F/T reading) or of a set-point stream (the planner's
        x_d'' and its acceleration) latches the safe hold, named
    joint state (stamp, q, qd or named) --> the guard (stamps forward, not from the future) --> ReplicaLoop (the
        control grid, the loop's own health and hold) --> the driver's command (tau, or tau - G(q)) and the stamp
        of the state it was computed on (fic_core.command_stamp)
    teleoperation command --> one writer? --> the channel's replica port (booked, with TDPA corrected) -->
        CommandAuthority (inside the loop) --> x_d'
    planner pose and acceleration --> SetPointAuthority (inside the loop) --> x_d''
    F/T reading --> the driver's wrench frame --> F_R, sent back with the port's E_in at each joint state whose
        poses are due (the tick carries both: ``ReplicaTick.feedback``)

Every value comes in as a plain value (numbers, arrays, names), every message out as plain values; the node turns
them into and out of messages. Notices (what the caller should log) come back as (level, text), level one of info,
warning, error and repeated_warning / repeated_error (said at every message while their cause lasts: to be
throttled). The safe hold's reason is returned once, when it latches: it is said once, at once (the node logs it and
publishes /diagnostics), and from then on no joint state, command or set-point is taken: no torque goes out and the
robot's own command watchdog holds the arm (docs/SECURITY.md).
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .channel_ports import CHANNEL_PORT_NUMBERS, CHANNEL_PORT_SWITCHES, ReplicaChannelPort
from .errors import FicInputError
from .exchanged_energy_ports import EXCHANGED_ENERGY_SWITCHES, ReplicaExchangedEnergy
from .input_authority import (
    AUTHORITY_PARAMETERS,
    AuthorityBounds,
    AuthorityParameters,
    CommandAuthority,
    RobotStreamGuard,
)
from .parameter_row import ParameterRow, parameter_set
from .record_batch_rows import RECORD_BATCH_ROWS
from .replica import ReplicaCommand
from .replica_driver import DRIVER_PARAMETERS, DriverParameters, ReplicaDriver
from .replica_loop import ReplicaLoop, ReplicaStep
from .replica_parameters import REPLICA_LOOP_ROWS, ReplicaLoopParameters
from .robot_model import RobotModel

Notice = tuple[str, str]

#: Every parameter of the replica, in the order the replica node declares them (config/replica.yaml's keys): the
#: loop's (the law, fic_core.replica_parameters), the driver's (fic_core.replica_driver), the input authority's
#: (fic_core.input_authority), the channel's replica port and the exchanged-energy observer.
REPLICA_PARAMETERS: dict[str, ParameterRow] = {
    **REPLICA_LOOP_ROWS, **DRIVER_PARAMETERS, **AUTHORITY_PARAMETERS, **CHANNEL_PORT_SWITCHES, **CHANNEL_PORT_NUMBERS,
    **EXCHANGED_ENERGY_SWITCHES, **RECORD_BATCH_ROWS}
#: The replica's parameters as one typed object, one field a row of REPLICA_PARAMETERS (fic_core.parameter_row):
#: ``ReplicaParameters.from_values(values)`` checks every value and refuses a name no row has, naming the nearest.
ReplicaParameters = parameter_set("ReplicaParameters", __name__, "replica", REPLICA_PARAMETERS.values(),
                                  "The replica's parameters (REPLICA_PARAMETERS), checked, one field a row.")

#: Robot-side streams that must have exactly one writer: the robot's driver, and the replica. The wrist's F/T reading
#: is one: it is F_R, which the replica sends the operator, and a second writer's force would be felt on the handle.
ROBOT_STREAMS = ("/joint_states", "/effort_controller/commands", "/ft_sensor/wrench")
#: Set-point streams the law acts on, at most one writer each: the planner's x_d'' and its acceleration (none when no
#: planner runs). The poses of two writers cannot be told apart, and flipping between them moves x_d'' (an outside
#: client's 0.3 m away moved a resting hand 0.34 m).
SET_POINT_STREAMS = ("/planner/desired_pose", "/planner/desired_accel")
#: The master port's E_in as the channel relays it (/master/port_energy on the operator's side): the channel-port
#: passivity controller of the replica's side spends it, so a second writer could fake the energy the operator put in
#: and, with that controller on, move the corrected set-point; without it, fake the port's books. One writer.
CHANNEL_STREAMS = ("/replica/master_port_energy",)
#: x_d': one writer (the channel, or the master without one); a second one's commands are refused while it lasts.
TELEOP_STREAM = "/replica/teleop_command"


def stream_owner(topic: str) -> str:
    """Whose the one legitimate writer of a guarded stream is (its name before any remap)."""
    if topic in ROBOT_STREAMS:
        return "the robot's"
    return "the channel's" if topic in CHANNEL_STREAMS else "the planner's"


@dataclass(frozen=True)
class ReplicaTotals:
    """The replica's counts over a run so far."""

    limit_violation_ticks: int        # control ticks whose command or measured state broke a limit
    shaped_ticks: int                 # control ticks the postural optimisation changed
    passivity_min_margin: float       # the task-space port's smallest W - (V - V0) [J]
    passivity_violation_ticks: int    # ticks that margin was below zero
    holds: int                        # the loop's own holds (fic_core.loop_health)


@dataclass
class ReplicaTick:
    """What one joint state produced, for the caller to send."""

    step: ReplicaStep                        # the loop's step (poses and status due, the tick's report)
    command: NDArray[np.float64] | None      # the driver's command to publish (None: nothing)
    state_stamp_ns: int | None               # the joint state ``command`` was computed on (its label)
    hold_began: bool = False                 # the loop's own hold began at this state: say so at once
    # F_R to send the master now (the last F/T reading in the base frame, at pose_rate once the law has ticked and a
    # reading came) and the channel port's E_in to travel with it; None: nothing to send at this state.
    feedback: tuple[NDArray[np.float64], float] | None = None


class ReplicaStation:
    """The replica's loop, its input guarding and its driver semantics for the replica's parameters (module
    docstring). ``channel_port``: the channel's replica port, when the caller holds both ends (the in-process runner
    sums the channel's balance); else one is built from the parameters. The loop takes its part and keeps it as it
    runs it (``loop.parameters``, replaced by ``configure``)."""

    def __init__(self, parameters: ReplicaParameters, robot: RobotModel | None = None,
                 channel_port: ReplicaChannelPort | None = None) -> None:
        p = parameters
        self.driver = ReplicaDriver(p.part(DriverParameters))
        robot = RobotModel() if robot is None else robot
        # What an outside input may ask of the arm (fic_core.input_authority): bounded commands (the loop's
        # authority), one writer per guarded stream (the stream guard's); a breach holds the arm.
        self.authority = CommandAuthority(AuthorityBounds.from_parameters(p.part(AuthorityParameters)))
        self.loop = ReplicaLoop(p.part(ReplicaLoopParameters), robot, self.driver.limits(robot),
                                self.authority)   # FicInputError if bad
        self.streams = RobotStreamGuard(future_tolerance=p.command_future_tolerance)
        self.channel_port = ReplicaChannelPort(p.channel_passivity_control, p.channel_energy_window) \
            if channel_port is None else channel_port
        self.exchanged = ReplicaExchangedEnergy(1.0 / self.loop.parameters.control_rate) \
            if p.exchanged_energy_observer else None
        self.state_stamp_ns: int | None = None   # the joint state the last torque was computed on
        self.feedback_force: NDArray[np.float64] | None = None   # F_R of the last F/T reading (None: none yet)

    @property
    def held(self) -> bool:
        """The safe hold (a second writer, a foreign joint-state stamp): latched until a restart."""
        return self.streams.held

    @property
    def hold_reason(self) -> str | None:
        return self.streams.reason if self.streams.held else None

    @property
    def base_frame(self) -> str:
        """The frame the driver declares its readings in (the robot's base)."""
        return self.driver.base_frame

    @property
    def last_command(self) -> ReplicaCommand | None:
        """The last control tick's report (None before the first)."""
        return self.loop.last_command

    @property
    def offset_in_use(self) -> NDArray[np.float64]:
        """x_d' as the law uses it now (held while the master is stale, given back on a resume)."""
        return self.loop.desired.offset

    @property
    def passivity_margin(self) -> float:
        """The task-space port's smallest W - (V - V0) over its axes at the last tick [J]."""
        return float(self.loop.passivity.margin.min())

    def totals(self) -> ReplicaTotals:
        loop = self.loop
        return ReplicaTotals(loop.controller.violation_ticks, loop.controller.shaped_ticks,
                             loop.passivity.min_margin, loop.passivity.violation_ticks, loop.health.holds)

    def configure(self, changes: Mapping[str, Any]) -> ReplicaLoopParameters:
        """The loop's run-time parameters, all or none (FicInputError names the bad one); returns the loop's
        parameters now in force. The other parts' (driver, input authority, channel port) are fixed at start."""
        fixed = [name for name in changes if name in REPLICA_PARAMETERS and name not in REPLICA_LOOP_ROWS]
        if fixed:
            raise FicInputError(f"{', '.join(fixed)}: fixed at start (only the loop's parameters change at run time)")
        return self.loop.configure(changes)

    # --- who writes ------------------------------------------------------------------------------------------
    def writers(self, topic: str, names: Sequence[str], stream: str | None = None) -> str:
        """The writers now on a guarded ``topic`` (their node names, from the graph; ``stream``: its name before a
        remap, default ``topic``); a second one latches the safe hold. Returns its reason the first time, ""
        otherwise."""
        return self.streams.publishers(topic, list(names), stream_owner(stream or topic))

    def matched(self, topic: str, writers: int, stream: str | None = None) -> str:
        """The middleware's count of writers matched to the reader of a guarded ``topic`` (before discovery has
        their names; ``stream`` as for ``writers``); a second one latches the safe hold. Returns its reason the
        first time, "" otherwise."""
        return self.streams.matched(topic, writers, stream_owner(stream or topic))

    # --- inputs ----------------------------------------------------------------------------------------------
    def admits_joint_state(self, stamp: float, now: float) -> tuple[bool, str]:
        """Whether the joint state stamped ``stamp`` [s] may drive the law (``now``: the receiver's clock), and the
        reason of a safe hold it latched ("" if none). Not in the safe hold, stamps forward, not from the future."""
        usable, reason = self.streams.joint_state(stamp, now)
        if not usable or self.streams.held:
            self.loop.counts["rejected_joint_states"] += 1
            return False, reason
        return True, reason

    def skips(self, stamp: float) -> bool:
        """Whether the joint state stamped ``stamp`` is counted and dropped unread (between control ticks, when not
        every state is answered): the node need not decode it."""
        if self.loop.skips(stamp):
            self.loop.skip()
            return True
        return False

    def teleoperation_command(self, stamp_ns: int, now: float, *, mode: int, haptic_gain: float,
                              workspace_scale: float, velocity_gain: float, handle_position: ArrayLike,
                              desired_offset: ArrayLike, writers: int = 1,
                              master_input_energy: float | None = None) -> list[Notice]:
        """A teleoperation command as delivered at ``now`` (``writers``: how many write its topic;
        ``master_input_energy``: the master port's E_in, when it travels with the command). FicInputError for
        non-finite values (nothing taken). While a second writer is on the topic no command can be told from the
        other's: x_d' is held, as when the master is silent."""
        counts = self.loop.counts
        if self.streams.held:
            counts["rejected_teleop_commands"] += 1
            return []
        if writers > 1:
            reason = f"{writers} publishers on it"
            self.authority.refuse(reason)
            counts["rejected_teleop_commands"] += 1
            return [("repeated_error", f"refusing {TELEOP_STREAM}: {reason}, one is the channel's; holding the last "
                                       f"good x_d' while they last ({self.authority.refused} refused so far)")]
        if master_input_energy is not None:
            self.channel_port.receive_energy(master_input_energy)
        offset = self.channel_port.delivery(desired_offset, now)   # the channel's replica port
        verdict, notice = self.loop.teleoperation_command(
            stamp_ns, now, mode=mode, haptic_gain=haptic_gain, workspace_scale=workspace_scale,
            velocity_gain=velocity_gain, handle_position=handle_position, desired_offset=offset)
        notices: list[Notice] = []
        authority = self.authority
        if not verdict.accepted:
            notices.append(("repeated_error", f"refusing {TELEOP_STREAM}: {verdict.reason}; keeping the last good "
                                              f"x_d' ({authority.refused} refused so far)"))
        elif verdict.clamped or verdict.rate_limited:
            notices.append(("repeated_warning", f"{TELEOP_STREAM}: {verdict.reason} ({authority.clamped} outside the "
                                                f"workspace, {authority.rate_limited} rate-limited so far)"))
        if notice:
            notices.append(("warning", notice))
        return notices

    def master_port_energy(self, input_energy: float) -> None:
        """The master port's E_in as the channel delivered it (FicInputError if not finite)."""
        self.channel_port.receive_energy(input_energy)

    def planner_pose(self, stamp_ns: int, position: ArrayLike, quaternion_xyzw: ArrayLike,
                     now: float) -> list[Notice]:
        """x_d'' of the planner, bounded by the set-point authority (FicInputError for bad values)."""
        if self.streams.held:   # the safe hold: no set-point is taken any more
            self.loop.counts["rejected_planner_poses"] += 1
            return []
        bounded = self.loop.planner_authority
        before = bounded.clamped + bounded.rate_limited
        self.loop.add_planner_pose(stamp_ns, position, quaternion_xyzw, now)
        if bounded.clamped + bounded.rate_limited == before:
            return []
        return [("repeated_warning", f"/planner/desired_pose: {bounded.last_reason} ({bounded.clamped} outside the "
                                     f"workspace, {bounded.rate_limited} rate-limited so far)")]

    def planner_acceleration(self, acceleration: ArrayLike, now: float) -> None:
        if self.streams.held:
            self.loop.counts["rejected_planner_poses"] += 1
            return
        self.loop.add_planner_acceleration(acceleration, now)

    def wrench(self, frame_id: str, force: ArrayLike,
               torque: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], FicInputError | None]:
        """F_R from the F/T reading: (force, moment about the TCP) in the base frame by the driver's declared frame,
        sign and reference point, and the error that refused it (then zero: the operator feels nothing rather
        than a wrong push)."""
        command = self.loop.last_command
        try:
            force, torque = self.driver.wrench_frame.at_tcp(frame_id, force, torque,
                                                            None if command is None else command.tcp_rotation)
        except FicInputError as exc:
            self.loop.counts["rejected_wrenches"] += 1
            self.feedback_force = np.zeros(3)
            self.loop.measure_contact_force(math.inf)   # contact unknown: taken as contact (no offset feedforward)
            return self.feedback_force, np.zeros(3), exc
        self.loop.counts["wrenches"] += 1
        self.feedback_force = force
        self.loop.measure_contact_force(float(np.linalg.norm(force)))
        return force, torque, None

    # --- the control step ------------------------------------------------------------------------------------
    def tick_dynamics(self) -> NDArray[np.float64]:
        """C(q, qd) qd + G(q) of the robot model at the last joint state [N m] (a copy)."""
        return self.loop.robot.nonlinear_effects.copy()

    def joint_state(self, time: float, now: float, q: NDArray[np.float64], qd: NDArray[np.float64],
                    stamp_ns: int | None = None, steady_now: float | None = None) -> ReplicaTick:
        """One admitted joint state (q, qd in the law's joint order, stamped ``time`` [s], received at ``now``;
        ``stamp_ns``: its stamp as the command's label names it; ``steady_now``: the steady clock, for the driver's
        ramp-down). The command for the driver, from a torque the state has not grown too old for."""
        notices: list[Notice] = []
        ramp = self.driver.ramp
        if ramp is not None and steady_now is not None and ramp.fresh(steady_now):   # after a ramp-down
            notices.append(("warning", "joint states are back: the law takes over from the ramp (slewed at the "
                                       "torque-rate limit)"))
        loop = self.loop
        holds = loop.health.holds
        self.state_stamp_ns = stamp_ns
        step = loop.joint_state(time, now, q, qd)
        step = loop.ready(step, time, now)   # not grown old inside the tick
        step.notices[:0] = notices
        if self.exchanged is not None and step.command is not None:
            self.exchanged.observe(step.command, loop.controller.controller)
        feedback = None
        if step.poses_due and loop.last_command is not None and self.feedback_force is not None:
            feedback = (self.feedback_force, self.channel_port.sent(self.feedback_force))   # E_in travels with F_R
        return ReplicaTick(step, self.driver.command_to_send(step.torque, loop.robot), stamp_ns,
                           loop.health.holds != holds, feedback)

    def named_joint_state(self, time: float, now: float, names: Sequence[str], positions: Sequence[float],
                          velocities: Sequence[float], stamp_ns: int | None = None,
                          steady_now: float | None = None) -> tuple[ReplicaTick, FicInputError | None]:
        """A joint state as the driver sends it (names, positions, velocities in its order): picked into the law's
        order, or refused (the error, and the last command again, labelled with the state it was computed on)."""
        try:
            q, qd = self.driver.joint_order.pick(names, positions, velocities)
        except FicInputError as exc:
            repeated = self.driver.command_to_send(self.loop.refuse_joint_state(), self.loop.robot)
            return ReplicaTick(ReplicaStep(), repeated, self.state_stamp_ns), exc
        return self.joint_state(time, now, q, qd, stamp_ns, steady_now), None

    def ramp(self, steady_now: float) -> tuple[NDArray[np.float64] | None, list[Notice]]:
        """At the driver's check: its ramp's command toward the gravity-only hold when no valid joint state came for
        joint_state_timeout on the steady clock (None: nothing to send; docs/HARDWARE.md)."""
        command, started = self.driver.ramp_command(steady_now)
        if not started:
            return command, []
        counts = self.loop.counts
        counts["ramp_downs"] = counts.get("ramp_downs", 0) + 1
        ramp = self.driver.ramp
        return command, [("error", f"no valid joint state for more than joint_state_timeout = {ramp.timeout:g} s: "
                                   f"ramping the torque command to the gravity-only hold over {ramp.ramp_time:g} s")]

    # --- reports ---------------------------------------------------------------------------------------------
    def guard_values(self) -> dict[str, str]:
        """The input guard's /diagnostics values (recorded in the bag, read back by the launcher's exit code)."""
        authority = self.authority
        return {"input_safe_hold": self.streams.reason if self.streams.held else "no",
                "refused_teleop_commands": str(authority.refused),
                "last_refusal": authority.last_refusal or "none",
                "clamped_teleop_commands": str(authority.clamped),
                "rate_limited_teleop_commands": str(authority.rate_limited),
                "skipped_joint_states": str(self.streams.skipped_states)}

    def statistics(self) -> dict[str, str]:
        return {**self.guard_values(), **self.loop.statistics()}


__all__ = ["CHANNEL_STREAMS", "ROBOT_STREAMS", "SET_POINT_STREAMS", "TELEOP_STREAM", "ReplicaStation", "ReplicaTick",
           "ReplicaTotals", "stream_owner"]
