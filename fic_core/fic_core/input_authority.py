"""What an input may ask of the replica arm: bounds on teleoperation commands, and one owner per robot stream.

The replica's inputs arrive over DDS, where any process on the same domain can publish (docs/SECURITY.md). Before
this module, one outside message with x_d' = (10, 10, 10) m drove the TCP at the Panda's 1.7 m/s speed limit,
stamps 10^6 s in the future or at epoch 0 were used, nonsense modes and gains went through without a word, and a
second /joint_states publisher with the right joint names took the arm. The postural optimisation keeps every
torque inside the Panda's limits, but it cannot tell a real command from a hostile one; these checks bound what
any single input can ask, before the law sees it.

``CommandAuthority`` checks a teleoperation command (paper Eq. 3 and the two modes: mode, K_H, s_M, k_v, x_M, x_d'):
- every field finite, the mode one of the two, K_H in [0, 1], s_M and k_v within the master's own parameter ranges:
  otherwise the command is refused whole (it is malformed; the last good x_d' stays);
- the stamp within ``future_tolerance`` ahead of the receiver's clock and at most ``max_age`` behind it (the
  channel's delay is inside that age): otherwise refused;
- x_d' inside the documented workspace box (``offset_lower`` to ``offset_upper``, relative to the pose the replica
  started from): clamped onto the box;
- x_d' moving no faster than ``max_offset_speed`` on the receiver's clock (a sender's stamps are its own to choose):
  a token bucket of distance, refilled at that speed and holding at most ``max_offset_burst`` (the channel delivers
  in bursts). A longer step is clamped: x_d' moves toward the commanded point by what the bucket holds, so a jump
  (a hostile sender; a real one after a blackout or a restart) is approached at the bounded speed, never taken.
Comparisons happen before any arithmetic on the values, and the clamp comes before the rate check, so finite but
huge values (1e3 m, 1e308) never overflow into Inf or NaN.

``SetPointAuthority`` puts the planner's x_d'' under the same bounds: inside the workspace box about the pose the
replica started from (clamped onto it), moving no faster than ``max_offset_speed`` with the same burst (a longer
step is approached at that speed). The first pose is only clamped: the replica gives its jump from the start pose
back at resume_speed (fic_core.desired_pose). Before this, an outside client's x_d'' 0.3 m away moved a resting
arm's hand 0.34 m in 2.5 s without a word.

``RobotStreamGuard`` watches the robot-side streams (/joint_states in, the torque commands out): each must have
exactly one publisher (the robot's driver; the replica); the set-point streams of the planner at most one, and
joint-state stamps must not go back and not lie in the receiver's future. A second writer of /joint_states is caught
twice: by the middleware's match of it to our reader, which comes with its first message or within a message or two of
it, and by the graph lookup of each stream's publishers every half second (alone, that window let a second writer's
states drive the arm 0.12 m on a loaded machine). The first breach latches a safe hold: the replica sends no more
torques, and the robot's own command watchdog holds the arm (the simulator: gravity compensation and damping after 50 ms
without a command; a Franka arm: libfranka's communication reflex stops it). A law held on joint states cannot be
trusted: a writer whose stamps run ahead of the robot's makes the robot's own states look old, so "the states that move
forward" are the intruder's. A hold is not lifted on its own: once a second writer was seen, no later joint state can be
trusted.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_array, finite_scalar
from .parameter_row import ParameterRow, number, parameter_set, rows_by_name

MODES = (0, 1)  # TeleoperationCommand MODE_OFFSET, MODE_VELOCITY


#: What an outside input may ask of the arm: the replica's parameters behind AuthorityBounds (config/replica.yaml
#: holds the values; part of the table the replica node declares, fic_core.replica_station). Fixed at start, as the
#: driver's rows are: they are the envelope a session's safety was judged in (docs/SECURITY.md), and a live change
#: would let any client on the domain widen it with one parameter request, mid-motion.
AUTHORITY_PARAMETERS: dict[str, ParameterRow] = rows_by_name(
    number("offset_workspace", 0.01, 2.0, "x_d' is clamped to +- this on each axis, about the start pose [m] "
                                          "(fic_core.input_authority)", read_only=True),
    number("max_offset_speed", 0.01, 10.0, "x_d' moves toward a teleoperation command no faster than this, on "
                                           "this node's clock [m/s]", read_only=True),
    number("max_offset_burst", 0.0, 1.0, "x_d' may move this far at once, for bursts of delayed commands [m]",
           read_only=True),
    number("command_future_tolerance", 0.0, 10.0, "commands and joint states stamped further ahead of this node's "
                                                  "clock are refused [s]", read_only=True),
    number("max_command_age", 0.05, 600.0, "teleoperation commands stamped longer ago are refused [s] (the "
                                           "channel's delay must fit inside it; the launcher raises it with "
                                           "--delay)", read_only=True),
)
#: Those rows as one typed object (fic_core.parameter_row.parameter_set).
AuthorityParameters = parameter_set("AuthorityParameters", __name__, "input authority", AUTHORITY_PARAMETERS.values(),
                                    "The input authority's parameters (AUTHORITY_PARAMETERS), checked, one field a "
                                    "row.")


@dataclass(frozen=True)
class AuthorityBounds:
    """The bounds of CommandAuthority (module docstring); defaults documented in docs/SECURITY.md."""

    # The workspace of x_d' [m], per axis, about the replica's start pose: the Panda reaches 0.855 m from its base,
    # and the paper's tasks move x_d' by at most about 0.3 m (E1 steers around obstacles 0.1-0.2 m off the circle).
    offset_lower: tuple[float, float, float] = (-0.5, -0.5, -0.5)
    offset_upper: tuple[float, float, float] = (0.5, 0.5, 0.5)
    max_offset_speed: float = 1.0       # [m/s] below the Panda's 1.7 m/s TCP limit; a hand moves x_d' < 0.5 m/s
    max_offset_burst: float = 0.05      # [m] x_d' may move this far at once (a burst of delayed commands)
    future_tolerance: float = 0.5       # [s] a stamp this far ahead of our clock is refused (clock skew allowance)
    max_age: float = 3.0                # [s] an older stamp is refused (the channel's delay must fit inside it)
    haptic_gain: tuple[float, float] = (0.0, 1.0)        # K_H, paper Eq. 3
    workspace_scale: tuple[float, float] = (0.01, 100.0)  # s_M, the master's parameter range
    velocity_gain: tuple[float, float] = (0.0, 100.0)     # k_v [1/s], the master's parameter range
    max_handle_position: float = 10.0   # [m] |x_M| per axis; a haptic handle moves a few cm

    @classmethod
    def from_parameters(cls, parameters: AuthorityParameters) -> AuthorityBounds:
        """The bounds from the replica's parameters (config/replica.yaml): ``offset_workspace`` (half the box's
        side), ``max_offset_speed``, ``max_offset_burst``, ``command_future_tolerance``, ``max_command_age``."""
        half = parameters.offset_workspace
        return cls(offset_lower=(-half, -half, -half), offset_upper=(half, half, half),
                   max_offset_speed=parameters.max_offset_speed, max_offset_burst=parameters.max_offset_burst,
                   future_tolerance=parameters.command_future_tolerance, max_age=parameters.max_command_age)

    def __post_init__(self) -> None:
        lower = finite_array("offset_lower", self.offset_lower, (3,))
        upper = finite_array("offset_upper", self.offset_upper, (3,))
        if np.any(lower >= upper):
            raise FicInputError(f"offset_lower must be below offset_upper on every axis, got {lower} and {upper}")
        finite_scalar("max_offset_speed", self.max_offset_speed, minimum=0.0, minimum_inclusive=False)
        finite_scalar("max_offset_burst", self.max_offset_burst, minimum=0.0)
        finite_scalar("future_tolerance", self.future_tolerance, minimum=0.0)
        finite_scalar("max_age", self.max_age, minimum=0.0, minimum_inclusive=False)
        for name in ("haptic_gain", "workspace_scale", "velocity_gain"):
            low, high = getattr(self, name)
            if not (math.isfinite(low) and math.isfinite(high) and low <= high):
                raise FicInputError(f"{name} range must be finite with low <= high, got {(low, high)}")
        finite_scalar("max_handle_position", self.max_handle_position, minimum=0.0, minimum_inclusive=False)


@dataclass
class CommandVerdict:
    """What CommandAuthority made of one command: use ``offset`` if ``accepted``; ``reason`` says what was wrong
    (refused, or clamped when accepted), empty for a clean command."""

    accepted: bool
    offset: NDArray[np.float64] | None
    clamped: bool = False        # x_d' was outside the workspace box
    rate_limited: bool = False   # x_d' moved toward the command by the rate bound only
    reason: str = ""


def _in_range(name: str, value: float, bounds: tuple[float, float]) -> str:
    return "" if bounds[0] <= value <= bounds[1] else f"{name} {value:g} outside [{bounds[0]:g}, {bounds[1]:g}]"


@dataclass
class CommandAuthority:
    """Checks teleoperation commands against AuthorityBounds (module docstring). Counts what it refused."""

    bounds: AuthorityBounds = field(default_factory=AuthorityBounds)
    accepted: int = 0
    refused: int = 0
    clamped: int = 0        # onto the workspace box
    rate_limited: int = 0   # approached at max_offset_speed (normal after a restart; a flood of jumps is not)
    last_refusal: str = ""  # why the last refused command was refused (for the record: one line, no history)

    def __post_init__(self) -> None:
        self._lower = np.asarray(self.bounds.offset_lower, dtype=np.float64)
        self._upper = np.asarray(self.bounds.offset_upper, dtype=np.float64)
        self._last_received: float | None = None      # receiver's clock at the last accepted command
        self._last_offset: NDArray[np.float64] | None = None
        self._allowance = 0.0                          # distance x_d' may still move now [m]

    def reset(self) -> None:
        """Forget the last accepted command (the rate bound starts afresh)."""
        self._last_received = self._last_offset = None
        self._allowance = 0.0

    def check(self, *, stamp: float, now: float, mode: int, haptic_gain: float, workspace_scale: float,
              velocity_gain: float, handle_position: ArrayLike, desired_offset: ArrayLike) -> CommandVerdict:
        """The verdict on one command. ``stamp``: its header stamp [s] (the sender's clock); ``now``: ours."""
        verdict = self._judge(stamp, now, mode, haptic_gain, workspace_scale, velocity_gain, handle_position,
                              desired_offset)
        if verdict.accepted:
            self.accepted += 1
            self.clamped += int(verdict.clamped)
            self.rate_limited += int(verdict.rate_limited)
            self._last_received = now
            self._last_offset = verdict.offset
        else:
            self.refuse(verdict.reason)
        return verdict

    def refuse(self, reason: str) -> None:
        """Count a command refused, here or before it reached ``check`` (a second writer on its topic)."""
        self.refused += 1
        self.last_refusal = reason

    def _judge(self, stamp: float, now: float, mode: int, haptic_gain: float, workspace_scale: float,
               velocity_gain: float, handle_position: ArrayLike, desired_offset: ArrayLike) -> CommandVerdict:
        bounds = self.bounds
        handle = np.asarray(handle_position, dtype=np.float64)
        offset = np.asarray(desired_offset, dtype=np.float64)
        scalars = (stamp, haptic_gain, workspace_scale, velocity_gain)
        if not (all(math.isfinite(v) for v in scalars) and np.all(np.isfinite(handle)) and np.all(np.isfinite(offset))):
            return CommandVerdict(False, None, reason="a field is not finite")
        if handle.shape != (3,) or offset.shape != (3,):
            return CommandVerdict(False, None, reason="x_M and x_d' must be 3-vectors")
        if mode not in MODES:
            return CommandVerdict(False, None, reason=f"mode {mode} is neither offset (0) nor velocity (1)")
        problems = [text for text in (_in_range("K_H", haptic_gain, bounds.haptic_gain),
                                      _in_range("s_M", workspace_scale, bounds.workspace_scale),
                                      _in_range("k_v", velocity_gain, bounds.velocity_gain)) if text]
        if np.any(np.abs(handle) > bounds.max_handle_position):
            problems.append(f"|x_M| above {bounds.max_handle_position:g} m")
        if problems:
            return CommandVerdict(False, None, reason="; ".join(problems))
        # Compared, not subtracted first: with stamp = 1e308 the difference is still finite, and both comparisons
        # are exact for any finite values.
        if stamp > now + bounds.future_tolerance:
            return CommandVerdict(False, None, reason=f"stamped {stamp - now:.3g} s in the receiver's future "
                                                      f"(tolerance {bounds.future_tolerance:g} s)")
        if stamp < now - bounds.max_age:
            return CommandVerdict(False, None, reason=f"stamped {now - stamp:.3g} s in the past (at most "
                                                      f"{bounds.max_age:g} s)")
        clamped_offset = np.clip(offset, self._lower, self._upper)
        outside = bool(np.any(clamped_offset != offset))
        rate_limited = False
        reasons = [f"x_d' {np.array2string(offset, precision=3)} m outside the workspace "
                   f"[{self._lower.tolist()}, {self._upper.tolist()}]"] if outside else []
        if self._last_offset is not None and self._last_received is not None:
            # Both offsets lie in the box: the step is finite and at most the box's diagonal.
            elapsed = max(now - self._last_received, 0.0)
            self._allowance = min(self._allowance + bounds.max_offset_speed * elapsed, bounds.max_offset_burst)
            step_vector = clamped_offset - self._last_offset
            step = float(np.linalg.norm(step_vector))
            if step > self._allowance:
                reasons.append(f"x_d' jumps {step:.3g} m, beyond {bounds.max_offset_speed:g} m/s (burst "
                               f"{bounds.max_offset_burst:g} m)")
                clamped_offset = self._last_offset + step_vector * (self._allowance / step)
                step = self._allowance
                rate_limited = True
            self._allowance -= step
        if reasons:
            return CommandVerdict(True, clamped_offset, outside, rate_limited, "; ".join(reasons) + ": clamped")
        return CommandVerdict(True, clamped_offset)


class _BoundedPoint:
    """A point kept inside a box and moved toward each new target no faster than a speed, with a burst allowance
    (the token bucket of distance of CommandAuthority and SetPointAuthority)."""

    def __init__(self, lower: NDArray[np.float64], upper: NDArray[np.float64], speed: float, burst: float) -> None:
        self.lower, self.upper, self.speed, self.burst = lower, upper, speed, burst
        self.last: NDArray[np.float64] | None = None
        self.last_time: float | None = None
        self.allowance = 0.0

    def reset(self) -> None:
        self.last = self.last_time = None
        self.allowance = 0.0

    def take(self, target: NDArray[np.float64], now: float) -> tuple[NDArray[np.float64], bool, bool]:
        """The bounded point for ``target`` (finite, (3,)) at ``now``: (point, outside the box, rate-limited)."""
        clamped = np.clip(target, self.lower, self.upper)   # before any arithmetic: 1e308 stays finite
        outside = bool(np.any(clamped != target))
        rate_limited = False
        if self.last is not None and self.last_time is not None:
            self.allowance = min(self.allowance + self.speed * max(now - self.last_time, 0.0), self.burst)
            step_vector = clamped - self.last
            step = float(np.linalg.norm(step_vector))
            if step > self.allowance:
                clamped = self.last + step_vector * (self.allowance / step)
                step, rate_limited = self.allowance, True
            self.allowance -= step
        self.last, self.last_time = clamped, now
        return clamped, outside, rate_limited


@dataclass
class SetPointAuthority:
    """The planner's x_d'' inside the workspace box about the start pose, at a bounded speed (module docstring)."""

    bounds: AuthorityBounds = field(default_factory=AuthorityBounds)
    accepted: int = 0
    clamped: int = 0
    rate_limited: int = 0
    last_reason: str = ""

    def __post_init__(self) -> None:
        self._point: _BoundedPoint | None = None

    def start(self, start_position: ArrayLike) -> None:
        """The pose the replica started from: the box is about it."""
        start = finite_array("start_position", start_position, (3,))
        self._point = _BoundedPoint(start + np.asarray(self.bounds.offset_lower, dtype=np.float64),
                                    start + np.asarray(self.bounds.offset_upper, dtype=np.float64),
                                    self.bounds.max_offset_speed, self.bounds.max_offset_burst)

    def check(self, position: ArrayLike, now: float) -> NDArray[np.float64]:
        """The bounded x_d'' for the planner's ``position`` at ``now`` (the receiver's clock). FicInputError before
        ``start`` or for a non-finite position (nothing changes then)."""
        target = finite_array("planner_position", position, (3,))
        if self._point is None:
            raise FicInputError("a planner pose before the first joint state (no start pose to bound it about)")
        bounded, outside, rate_limited = self._point.take(target, finite_scalar("now", now))
        self.accepted += 1
        self.clamped += int(outside)
        self.rate_limited += int(rate_limited)
        if outside or rate_limited:
            reasons = ([f"x_d'' {np.array2string(target, precision=3)} m outside the workspace about the start "
                        "pose"] if outside else []) + \
                      ([f"x_d'' jumps beyond {self.bounds.max_offset_speed:g} m/s"] if rate_limited else [])
            self.last_reason = "; ".join(reasons) + ": clamped"
        return bounded


@dataclass
class RobotStreamGuard:
    """One owner per robot-side stream, and joint-state stamps that move forward (module docstring)."""

    future_tolerance: float = 0.5   # [s] a joint state stamped further ahead of the receiver's clock is foreign
    held: bool = False
    reason: str = ""
    skipped_states: int = 0         # joint states not used: stamps back in time or in the future

    def __post_init__(self) -> None:
        finite_scalar("future_tolerance", self.future_tolerance, minimum=0.0)
        self._last_stamp: float | None = None

    def _hold(self, reason: str) -> str:
        """Latch the hold; the reason is returned once, for the one error line."""
        if self.held:
            return ""
        self.held = True
        self.reason = reason
        return reason

    def publishers(self, topic: str, writers: list[str], owner: str = "the robot's") -> str:
        """The writers now on a robot-side or set-point ``topic`` (their node names; ``owner``: whose the one
        legitimate writer is); a second one latches the hold. Returns the reason the first time, "" otherwise."""
        if len(writers) > 1:
            return self._hold(f"{len(writers)} publishers on {topic} ({', '.join(writers)}); one is {owner}")
        return ""

    def matched(self, topic: str, writers: int, owner: str = "the robot's") -> str:
        """The middleware's count of writers matched to our reader of ``topic``, at each change: a second one
        latches the hold. Returns the reason the first time, "" otherwise."""
        if writers > 1:
            return self._hold(f"{writers} publishers matched on {topic}; one is {owner}")
        return ""

    def joint_state(self, stamp: float, now: float) -> tuple[bool, str]:
        """Whether a joint state stamped ``stamp`` may be used (``now``: the receiver's clock), and the reason of a
        hold it latched ("" if none). States stamped back in time or ahead of ``now`` are never used."""
        if not math.isfinite(stamp):
            self.skipped_states += 1
            return False, self._hold("a joint state with a non-finite stamp")
        if stamp > now + self.future_tolerance:
            self.skipped_states += 1
            return False, self._hold(f"a joint state stamped {stamp - now:.3g} s in the receiver's future")
        last = self._last_stamp
        # An equal stamp is the robot's own state again (lockstep republishes a step it has no answer to yet).
        if last is not None and stamp < last:
            self.skipped_states += 1
            return False, self._hold(f"joint-state stamps went back by {last - stamp:.3g} s (a second writer, or a "
                                     "restarted robot)")
        self._last_stamp = stamp
        return True, ""
