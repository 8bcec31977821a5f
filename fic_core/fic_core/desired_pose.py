"""The replica's desired pose x_d = x_d' + x_d'' (paper Eq. 7's set-point), from the two sampled streams.

x_d'  the teleoperated offset, from the master through the channel (100 Hz, delayed);
x_d'' the autonomous trajectory, from the planner (100 Hz), with its acceleration for the feedforward.

Between samples x_d' is rebuilt by ``LinkHold`` over the link's learned sample interval (interpolating by default,
so the feedforward acts at any link rate from 1 kHz to 5 Hz; fic_core.link_hold) and x_d'' is a first-order hold on
the planner's stamps (``SampledSetPoint``), so x_d moves smoothly at the control rate. Around them:

- No planner pose yet: x_d'' is the TCP pose at the first joint state. The jump to the planner's first pose is
  given back at ``resume_speed`` (``ShrinkingOffset``) while the planner's output moves on underneath; a silent
  planner leaves its last value.
- Staleness watchdog: no teleoperation command for ``master_timeout`` (by receipt) -> x_d' is held where it was.
  When commands return (and for the very first one) the difference between the held and the commanded x_d' is
  given back at ``resume_speed``: x_d does not jump at a resume.
- After the replica's own hold (fic_core.loop_health): x_d moved on while the arm was held, by as much as the
  set-points moved meanwhile (225 mm after a 6 s hold under a 40 % CPU quota). The law does not come back onto that
  error: ``anchor`` puts x_d at the arm's TCP at the resume and the difference is given back at ``resume_speed``,
  as the jumps above, so the FIC never starts far from its attractor (its saturated force with no damping took the
  wrist to 0.73 of its datasheet speed within 0.3 s of such a resume, docs/RESULTS.md "Stress"). The give-backs
  still running at the anchor end there: that one give-back replaces them, so x_d moves from the set-point's own
  motion at resume_speed at most (two left running beside it moved it at twice that, away from an arm at rest).
- Feedforward acceleration (beyond paper Eq. 7, fic_core.replica): the planner's own (while fresh), plus the
  estimate of x_d''s acceleration from the command stamps (while not stale; with the contact gate on, not within
  a round trip of the link after a contact: fic_core.offset_feedforward_gate). A jump being given back moves at
  constant speed: it adds none.
- First use of a teleoperation command: its age at the control tick that first used it is the pipeline latency
  plus the channel's hold; kept with it so a status published at a lower rate still carries it exactly.

Times: ``now`` is the receiver's clock (the node clock; simulated time in lockstep). Stamps are integer
nanoseconds (exact, as in a ROS header) where they are handed back, seconds where they enter a hold.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_array, finite_scalar
from .link_hold import LinkHold
from .offset_feedforward_gate import OffsetFeedforwardGate
from .set_point import SampledSetPoint, ShrinkingOffset

#: An older planner acceleration is not fed forward (the planner publishes at 100 Hz) [s].
FEEDFORWARD_TIMEOUT_S = 0.05
#: A planner sample gap longer than this restarts x_d'''s velocity and acceleration estimates from rest [s] (the
#: planner publishes at 100 Hz on this machine; the link's x_d' learns its own interval, fic_core.link_hold).
SET_POINT_MAX_GAP_S = 0.1


@dataclass(frozen=True)
class DesiredPoseParameters:
    """The settings of ``DesiredPose`` (the replica's parameters of the same names)."""

    master_timeout: float = 0.5                 # [s] teleoperation commands older than this: x_d' is held
    resume_speed: float = 0.1                   # [m/s] jumps of x_d' and x_d'' are given back at this speed
    set_point_acceleration_filter: float = 0.05  # [s] low-pass of the acceleration estimate of x_d'
    set_point_extrapolation: float = 0.015      # [s] first-order hold of x_d'' at most this long
    planner_feedforward: bool = True            # feed the planner's acceleration forward
    offset_feedforward: bool = True             # feed x_d''s estimated acceleration forward
    use_planner_orientation: bool = False       # track the planner's orientation (else: the start orientation)
    interpolate_link_samples: bool = True       # x_d' between link samples: interpolated (else extrapolated)
    # With offset_feedforward_contact_gate, after a contact (|F_R| at or above offset_feedforward_contact_force [N])
    # the offset feedforward waits one round trip of the link plus offset_feedforward_settle [s]
    # (fic_core.offset_feedforward_gate).
    offset_feedforward_contact_gate: bool = False
    offset_feedforward_contact_force: float = 1.0
    offset_feedforward_settle: float = 0.5

    def __post_init__(self) -> None:
        finite_scalar("master_timeout", self.master_timeout, minimum=0.0, minimum_inclusive=False)
        finite_scalar("resume_speed", self.resume_speed, minimum=0.0, minimum_inclusive=False)
        finite_scalar("set_point_acceleration_filter", self.set_point_acceleration_filter, minimum=0.0)
        finite_scalar("set_point_extrapolation", self.set_point_extrapolation, minimum=0.0)
        OffsetFeedforwardGate(self.offset_feedforward_contact_force, self.offset_feedforward_settle)  # checks both


@dataclass
class DesiredPoseSample:
    """x_d at one control tick."""

    position: NDArray[np.float64]                 # x_d = x_d'' + x_d' [m] (3,)
    rotation: NDArray[np.float64]                 # R_d (3, 3)
    acceleration: NDArray[np.float64] | None      # the feedforward a_d [m/s^2] (3,), None: none
    notices: list[str] = field(default_factory=list)  # what changed this tick (a watchdog turning stale)


class DesiredPose:
    """x_d = x_d' + x_d'' with its holds, its staleness watchdog and its give-backs (module docstring)."""

    def __init__(self, parameters: DesiredPoseParameters | None = None) -> None:
        self._parameters = DesiredPoseParameters() if parameters is None else parameters
        self._planner_hold = self._hold()
        self._offset_hold = self._link_hold()
        self._planner_jump = ShrinkingOffset()   # start pose - first planner pose, given back
        self._offset_jump = ShrinkingOffset()    # x_d' held - x_d' commanded at a resume, given back
        self._hold_jump = ShrinkingOffset()      # the TCP - x_d at the end of the loop's hold, given back
        self._anchor: NDArray[np.float64] | None = None   # the TCP the next update starts x_d from
        self.started = False
        self.start_position = np.zeros(3)
        self.start_rotation = np.eye(3)
        self._planner_position: NDArray[np.float64] | None = None   # x_d'' as last received
        self._planner_in_use: NDArray[np.float64] | None = None     # x_d'' in use
        self._planner_rotation: NDArray[np.float64] | None = None
        self._planner_acceleration: NDArray[np.float64] | None = None
        self._planner_acceleration_received = 0.0
        self._commanded_offset = np.zeros(3)   # x_d' as last received
        self._offset = np.zeros(3)             # x_d' in use (held while stale, given back on resume)
        self.master_stamp_ns = 0               # stamp of the last good teleoperation command [ns]
        self.master_received: float | None = None  # receiver time of the last good teleoperation command
        self.master_stale = False
        # The stamp of the command the last control tick used [ns]; None before any (a stamp of 0 is a command:
        # a simulated clock's first stamps can be 0).
        self.master_stamp_used_ns: int | None = None
        self.master_first_use_age = 0.0        # its age at the control tick that first used it [s]
        self.contact_force = 0.0               # |F_R| [N] as last measured (measure_contact_force)
        self._offset_feedforward_gate = OffsetFeedforwardGate(self._parameters.offset_feedforward_contact_force,
                                                              self._parameters.offset_feedforward_settle)

    def _hold(self) -> SampledSetPoint:
        p = self._parameters
        return SampledSetPoint(3, acceleration_time_constant=p.set_point_acceleration_filter,
                               max_extrapolation=p.set_point_extrapolation, max_sample_gap=SET_POINT_MAX_GAP_S)

    def _link_hold(self) -> LinkHold:
        p = self._parameters
        return LinkHold("interpolate" if p.interpolate_link_samples else "extrapolate", dimension=3,
                        acceleration_time_constant=p.set_point_acceleration_filter)

    @property
    def parameters(self) -> DesiredPoseParameters:
        return self._parameters

    @parameters.setter
    def parameters(self, value: DesiredPoseParameters) -> None:
        """New settings, taking effect at once; the holds keep their samples (a new link hold design starts afresh
        at the next sample)."""
        self._parameters = value
        self._offset_feedforward_gate.contact_force = value.offset_feedforward_contact_force
        self._offset_feedforward_gate.settle = value.offset_feedforward_settle
        self._planner_hold.acceleration_time_constant = value.set_point_acceleration_filter
        self._planner_hold.max_extrapolation = value.set_point_extrapolation
        self._offset_hold.acceleration_time_constant = value.set_point_acceleration_filter
        design = "interpolate" if value.interpolate_link_samples else "extrapolate"
        if design != self._offset_hold.design:
            self._offset_hold = self._link_hold()
            if self.master_received is not None:
                # The new hold starts from the newest command (so the next one is a segment from it, not a step),
                # and x_d' goes on from where it is: the difference is given back as after a resume.
                self._offset_hold.add(self.master_stamp_ns * 1e-9, self._commanded_offset, self.master_received)
                if not self.master_stale:
                    self._offset_jump.start(self._offset, self._commanded_offset, value.resume_speed)

    @property
    def has_planner(self) -> bool:
        return self._planner_position is not None

    @property
    def resuming(self) -> bool:
        """Whether a jump of x_d' is still being given back."""
        return self._offset_jump.active

    @property
    def offset(self) -> NDArray[np.float64]:
        """x_d' in use [m], a copy."""
        return self._offset.copy()

    @property
    def anchored(self) -> bool:
        """Whether the difference between x_d and the TCP at the last ``anchor`` is still being given back."""
        return self._hold_jump.active

    def anchor(self, position: ArrayLike) -> None:
        """The next ``update`` starts x_d at ``position`` (the TCP after the loop's hold) and gives the difference to
        the set-points back at resume_speed (module docstring)."""
        self._anchor = finite_array("anchor_position", position, (3,)).copy()

    @property
    def command_unused(self) -> bool:
        """Whether a teleoperation command has arrived that no control tick has used yet."""
        return self.master_received is not None and self.master_stamp_ns != self.master_stamp_used_ns

    def start(self, position: ArrayLike, rotation: ArrayLike) -> None:
        """The TCP pose at the first joint state: x_d'' (and R_d) until the planner speaks."""
        self.start_position = finite_array("start_position", position, (3,)).copy()
        self.start_rotation = finite_array("start_rotation", rotation, (3, 3)).copy()
        self.started = True

    def add_teleoperation(self, stamp_ns: int, offset: ArrayLike, now: float) -> str | None:
        """A teleoperation command's x_d' (sampled at ``stamp_ns``), received at ``now``. Returns a notice when
        commands are back after a stale period. Raises FicInputError on NaN/Inf (nothing changes then)."""
        commanded = finite_array("desired_offset", offset, (3,)).copy()
        now = finite_scalar("now", now)
        first = self.master_received is None
        resume = self.master_stale or first
        self._commanded_offset = commanded
        self.master_stamp_ns = int(stamp_ns)
        self.master_received = now
        if resume:
            # The hold restarts from rest: its own blend of a gap (50 ms) would take out the same jump as the
            # give-back below, once too often (x_d' first jumped by the held - commanded difference the other
            # way, then blended back at metres per second).
            self._offset_hold.reset()
        self._offset_hold.add(stamp_ns * 1e-9, commanded, now)
        notice = None
        if resume:  # the first command is approached the same way: no jump either
            if self.master_stale:
                notice = (f"teleoperation commands are back: moving x_d' to the new command at "
                          f"<= {self._parameters.resume_speed:g} m/s")
            self.master_stale = False
            self._offset_jump.start(self._offset, commanded, self._parameters.resume_speed)
        return notice

    def add_planner_pose(self, stamp_ns: int, position: ArrayLike, rotation: ArrayLike, now: float) -> None:
        """The planner's x_d'' (and its orientation, a rotation matrix), sampled at ``stamp_ns``."""
        position = finite_array("planner_position", position, (3,)).copy()
        rotation = finite_array("planner_rotation", rotation, (3, 3)).copy()
        self._planner_hold.add(stamp_ns * 1e-9, position, finite_scalar("now", now))
        self._planner_position = position
        self._planner_rotation = rotation

    def add_planner_acceleration(self, acceleration: ArrayLike, now: float) -> None:
        """The planner's acceleration of x_d'' [m/s^2], for the feedforward."""
        self._planner_acceleration = finite_array("planner_acceleration", acceleration, (3,)).copy()
        self._planner_acceleration_received = finite_scalar("now", now)

    def measure_contact_force(self, force_norm: float) -> None:
        """|F_R| [N], the replica's measured contact force (inf: a reading refused): after a contact the offset
        feedforward waits out its echo (fic_core.offset_feedforward_gate)."""
        self.contact_force = float(force_norm)

    def update(self, now: float, dt: float) -> DesiredPoseSample:
        """x_d for a control tick at ``now``, ``dt`` after the last one (the give-backs advance by dt)."""
        if not self.started:
            raise FicInputError("the desired pose has no start pose yet")
        notices: list[str] = []
        if self._anchor is not None:
            # The give-backs still running end here: x_d starts at the TCP and ONE give-back takes it to the raw
            # set-point (the planner's hold plus the commanded x_d'). Left running beside it, two aligned
            # give-backs moved x_d at twice resume_speed from the set-point's own motion, away from an arm at rest.
            self._offset_jump.stop()
            self._planner_jump.stop()
            if self._planner_position is not None:
                self._planner_in_use = self._planner_position   # the planner's first jump is not started either
        notice = self._update_offset(now, dt)
        if notice:
            notices.append(notice)
        position = self._update_planner(now, dt) + self._offset  # x_d = x_d'' + x_d'
        if self._anchor is not None:
            self._hold_jump.start(self._anchor, position, self._parameters.resume_speed)
            self._anchor = None
            position = position + self._hold_jump.offset   # this tick: the TCP itself
        elif self._hold_jump.active:
            position = self._hold_jump.apply(position, dt)
        p = self._parameters
        rotation = self._planner_rotation if p.use_planner_orientation and self._planner_rotation is not None \
            else self.start_rotation
        if self.command_unused:
            self.master_stamp_used_ns = self.master_stamp_ns
            self.master_first_use_age = now - self.master_stamp_ns * 1e-9
        return DesiredPoseSample(position, rotation, self._feedforward_acceleration(now), notices)

    def _update_offset(self, now: float, dt: float) -> str | None:
        """x_d' in use: the commanded one, held while stale, given back after a stale period."""
        p = self._parameters
        notice = None
        if self.master_received is not None and not self.master_stale and \
                now - self.master_received > p.master_timeout:
            self.master_stale = True
            self._offset_jump.stop()
            notice = (f"no teleoperation command for more than master_timeout = {p.master_timeout:g} s: holding "
                      f"the last desired offset {np.round(self._offset, 4)} (the replica stays under its FIC)")
        if self.master_stale:
            return notice
        commanded = self._offset_hold.position(now) if self._offset_hold.has_sample else self._commanded_offset
        self._offset = self._offset_jump.apply(commanded, dt)
        return notice

    def _update_planner(self, now: float, dt: float) -> NDArray[np.float64]:
        """x_d'' in use: the start pose until the planner speaks, then its hold with the first jump given back."""
        if self._planner_position is None:
            return self.start_position
        planner = self._planner_hold.position(now)
        if self._planner_in_use is None:  # the first planner pose: start from the start pose
            self._planner_jump.start(self.start_position, planner, self._parameters.resume_speed)
        self._planner_in_use = self._planner_jump.apply(planner, dt)
        return self._planner_in_use

    def _feedforward_acceleration(self, now: float) -> NDArray[np.float64] | None:
        p = self._parameters
        acceleration = None
        if p.planner_feedforward and self._planner_acceleration is not None and self._planner_in_use is not None \
                and now - self._planner_acceleration_received <= FEEDFORWARD_TIMEOUT_S:
            acceleration = self._planner_acceleration
        # With the contact gate: after a contact, not until its echo through the operator has passed
        # (fic_core.offset_feedforward_gate). The gate sees every tick, so switched on live it knows the last contact.
        free = self._offset_feedforward_gate.update(now, self.contact_force, self.master_first_use_age) \
            or not p.offset_feedforward_contact_gate
        if p.offset_feedforward and free and not self.master_stale and self._offset_hold.has_sample:
            offset_acceleration = self._offset_hold.acceleration(now)
            acceleration = offset_acceleration if acceleration is None else acceleration + offset_acceleration
        return acceleration
