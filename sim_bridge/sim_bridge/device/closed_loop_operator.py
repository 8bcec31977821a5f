"""A closed-loop virtual operator for the superimposition scene (paper E1): it watches a delayed video and reacts.

The scripted operator (virtual_operator.ScriptedOperator) plays moves timed in advance for one delay. This one
times its moves from what it sees, as the paper's operator did watching the replica on two cameras:

- SEEING: ``see(arrival, frame)`` hands it a camera frame -- the replica's TCP position and the pushable
  obstacle's position at capture -- when the frame arrives, i.e. after the backward channel's delay (the video
  goes over the same link as the force feedback).
- REACTING: a frame is used only ``reaction_time`` after it arrived. 0.25 s is the simple visual reaction time of
  the Model Human Processor: perceptual (100 ms) + cognitive (70 ms) + motor (70 ms) cycle times, 240 ms with a
  range of about 105-470 ms (Card, Moran and Newell 1983, "The Psychology of Human-Computer Interaction", ch. 2);
  measured simple reaction times to a visual onset are 0.19-0.25 s (Kosinski 2008, "A literature review on
  reaction time", Clemson University). The runner draws it per seed.
- PLANNING from what it sees: the robot's angle about the circle's centre in the latest usable frame, and its
  angular speed (the median over the frames of the last ``estimation_window`` seconds), predict when the replica
  will pass each obstacle. The operator moves its hand so that the offset reaches the replica for that passing:
  its command takes the one-way delay to arrive and the handle ``handle_lag`` to follow the hand, so it aims at
  the robot's phase at ``now + assumed_one_way_delay + handle_lag``. ``assumed_one_way_delay`` is the latency the
  operator has learnt by practice (an expert, as in the paper); the runner gives it the cell's delay. A frame's
  capture time is its arrival minus that latency. Its own offset is in what it sees; it takes it out with an
  efference copy (von Holst and Mittelstaedt 1950): the hand target it held one latency + handle lag before the
  capture, which is the offset the replica was following then.
- MOVES: the same shapes as the E1 script (operator_scripts.SUPERIMPOSITION_DEFAULTS): inward and up around the
  fixed obstacle on every lap; the sweep through the pushable obstacle on every lap on which it is SEEN still on
  the circle's path (the script does it on the first lap only, blind to the outcome). A move, once started, is
  played to its end on the crossing time predicted at its start (a planned reach is ballistic; re-planning every
  frame would chase the noise of the robot's own contacts).
- FEELING: the hand is virtual_operator.Hand, a spring-damper on the handle; the master's force moves the handle
  against it, and the hand's lean-in (its correction term) is how the operator pushes through a felt force.

- VARYING (off by default; the claim sweep turns it on, docs/EXPERIMENTS.md "Claims"): no two moves alike. With a
  ``seed``, each move is played with its own amplitude scale (drawn in ``move_amplitude_range``), its own duration
  scale of the hold and ramp times (``move_duration_range``) and its own shift of its timing
  (+-``move_timing_spread`` s), drawn before it starts; and the hand wanders: smooth raised-cosine excursions of
  ``wander_amplitude_range`` metres in a random direction, lasting ``wander_period_range`` seconds, starting at
  exponentially distributed gaps of mean ``wander_mean_gap`` s (a hand that is never quite still, at random times).

With nothing seen moving yet (the robot at rest before its circle starts, or no frame arrived) the hand stays at
the origin: the operator does not know when the robot will come.
"""
from __future__ import annotations

import math
from bisect import bisect_right
from collections import deque
from dataclasses import dataclass
from typing import Mapping, NamedTuple, Sequence

import numpy as np
from numpy.typing import NDArray

from fic_core.errors import FicInputError, finite_array, finite_scalar

Vector3 = NDArray[np.float64]
#: The video's frame rate [Hz]: a webcam's.
VIDEO_RATE_HZ = 30.0


class Frame(NamedTuple):
    """What one camera frame shows, in the robot's base frame [m], and the video's own time stamp [s]: the video
    plays at its capture rate, so motion is seen at its true speed whatever the link adds."""

    stamp: float
    tcp: Vector3                     # the replica's TCP
    pushable_obstacle: Vector3       # the pushable obstacle's centre


@dataclass(frozen=True)
class ClosedLoopParameters:
    reaction_time: float = 0.25              # [s] module docstring (Card, Moran and Newell 1983)
    assumed_one_way_delay: float = 0.2       # [s] the latency the operator has learnt (runner: the cell's delay)
    handle_lag: float = 0.15                 # [s] the handle behind the hand (the script's figure)
    estimation_window: float = 1.0           # [s] of seen frames for the angular speed
    min_angular_speed: float = 0.3           # [rad/s] slower than this the robot is not seen circling
    circle_centre: tuple[float, float] = (0.45, 0.0)   # [m] x, y (sim_bridge.robot.scenes.CIRCLE_CENTRE)
    circle_radius: float = 0.10              # [m]
    on_path_distance: float = 0.06           # [m] the pushable obstacle's centre this close to the path: still there
    # The moves, as in the E1 script (operator_scripts.SUPERIMPOSITION_DEFAULTS):
    first_obstacle_angle_deg: float = 90.0
    second_obstacle_angle_deg: float = 270.0
    avoid_offset: float = 0.06
    avoid_lift: float = 0.06
    avoid_early: float = 0.3
    push_inward: float = 0.05
    push_outward: float = 0.06
    hold: float = 0.5
    ramp: float = 0.5
    push_hold: float = 0.3
    # VARYING (module docstring); the defaults play every move as the script does and never wander.
    seed: int | None = None
    move_amplitude_range: tuple[float, float] = (1.0, 1.0)
    move_duration_range: tuple[float, float] = (1.0, 1.0)
    move_timing_spread: float = 0.0           # [s]
    wander_amplitude_range: tuple[float, float] = (0.0, 0.0)   # [m]
    wander_period_range: tuple[float, float] = (1.0, 4.0)      # [s]
    wander_mean_gap: float = 3.0              # [s]

    def __post_init__(self) -> None:
        for name in ("reaction_time", "assumed_one_way_delay", "handle_lag", "avoid_offset", "avoid_lift",
                     "avoid_early", "push_inward", "push_outward", "push_hold"):
            finite_scalar(name, getattr(self, name), minimum=0.0)
        for name in ("estimation_window", "min_angular_speed", "circle_radius", "on_path_distance", "hold",
                     "ramp"):
            finite_scalar(name, getattr(self, name), minimum=0.0, minimum_inclusive=False)
        finite_array("circle_centre", self.circle_centre, shape=(2,))
        finite_scalar("move_timing_spread", self.move_timing_spread, minimum=0.0)
        finite_scalar("wander_mean_gap", self.wander_mean_gap, minimum=0.0, minimum_inclusive=False)
        for name, low_bound in (("move_amplitude_range", 0.0), ("move_duration_range", 1e-3),
                                ("wander_amplitude_range", 0.0), ("wander_period_range", 1e-3)):
            low, high = finite_array(name, getattr(self, name), shape=(2,))
            if not low_bound <= low <= high:
                raise FicInputError(f"{name} must be {low_bound:g} <= low <= high, got {(low, high)}")

    @classmethod
    def from_script_parameters(cls, script: Mapping[str, object], **changes: float) -> "ClosedLoopParameters":
        """The moves' numbers from an E1 script's parameters, so both operators make the same moves."""
        names = ("handle_lag", "first_obstacle_angle_deg", "second_obstacle_angle_deg", "avoid_offset",
                 "avoid_lift", "avoid_early", "push_inward", "push_outward", "hold", "ramp", "push_hold")
        values = {name: float(script[name]) for name in names if name in script}  # type: ignore[arg-type]
        if "circle_radius" in script:
            values["circle_radius"] = float(script["circle_radius"])  # type: ignore[arg-type]
        return cls(**{**values, **changes})


def _smooth(fraction: float) -> float:
    """The script's quintic smoothstep (minimum-jerk between points of rest)."""
    u = min(max(fraction, 0.0), 1.0)
    return u ** 3 * (10.0 - 15.0 * u + 6.0 * u ** 2)


def _profile(sigma: float, knots: Sequence[tuple[float, float]]) -> float:
    """Piecewise smoothstep through (time, value) knots; 0 outside them."""
    if sigma <= knots[0][0] or sigma >= knots[-1][0]:
        return 0.0
    for (t0, v0), (t1, v1) in zip(knots, knots[1:]):
        if sigma <= t1:
            return v0 + _smooth((sigma - t0) / (t1 - t0)) * (v1 - v0)
    return 0.0


class _Move(NamedTuple):
    name: str
    angle: float                                  # [rad] the obstacle's angle on the circle
    knots: tuple[tuple[float, float], ...]        # (time about the passing [s], scale of the direction)
    direction: Vector3


class ClosedLoopOperator:
    """Hand targets from delayed camera frames (module docstring). Call ``see`` as frames arrive and ``target``
    at the device's rate; both take the same clock."""

    def __init__(self, parameters: ClosedLoopParameters | None = None) -> None:
        self.parameters = p = parameters if parameters is not None else ClosedLoopParameters()
        first, second = math.radians(p.first_obstacle_angle_deg), math.radians(p.second_obstacle_angle_deg)
        radial_first = np.array([math.cos(first), math.sin(first), 0.0])
        radial_second = np.array([math.cos(second), math.sin(second), 0.0])
        # About the passing time of the replica at the obstacle (as the offset reaches it): the script's shapes.
        avoid = -p.avoid_offset * radial_first + np.array([0.0, 0.0, p.avoid_lift])
        self._moves = (
            _Move("avoid", first, ((-p.avoid_early - p.hold - p.ramp, 0.0), (-p.avoid_early - p.hold, 1.0),
                                   (p.hold, 1.0), (p.hold + p.ramp, 0.0)), avoid),
            _Move("push", second, ((-p.hold - p.ramp, 0.0), (-p.hold, -p.push_inward), (-0.1, -p.push_inward),
                                   (p.hold, p.push_outward), (p.hold + p.push_hold, p.push_outward),
                                   (p.hold + p.push_hold + p.ramp, 0.0)), radial_second),
        )
        self._frames: deque[tuple[float, Frame]] = deque()       # (arrival time, frame), arrival order
        self._usable: deque[tuple[float, float, float]] = deque()  # (capture time, stamp, corrected angle)
        # The angular speed of the frames in _usable, kept until they change (the device asks at 250 Hz, frames
        # come at 30 Hz and the median over them is the dearest part of a target): None before it is computed.
        self._speed: tuple[float | None] | None = None
        self._last_angle: float | None = None
        self._targets: list[tuple[float, Vector3]] = []          # efference copy: (time, hand target)
        self._target_times: list[float] = []
        self._latched: dict[str, float] = {}                     # move -> passing time it was started for
        self._done: dict[str, float] = {}                        # move -> the passing it last played
        self.pushable_on_path = True
        self.moves_started: list[tuple[str, float, float]] = []  # (move, start time, predicted passing time)
        # VARYING: the draws of each move's next playing (amplitude, duration scale, timing shift) and the wander.
        self._draws = np.random.default_rng(p.seed) if p.seed is not None else None
        self._variation = {move.name: self._draw_variation() for move in self._moves}
        self._wander: list[tuple[float, float, Vector3]] = []   # (start, duration, peak displacement)
        self._next_wander = self._draw_gap(0.0)

    def _draw_variation(self) -> tuple[float, float, float]:
        if self._draws is None:
            return 1.0, 1.0, 0.0
        p = self.parameters
        return (float(self._draws.uniform(*p.move_amplitude_range)), float(self._draws.uniform(*p.move_duration_range)),
                float(self._draws.uniform(-p.move_timing_spread, p.move_timing_spread)))

    def _draw_gap(self, now: float) -> float:
        if self._draws is None or self.parameters.wander_amplitude_range[1] <= 0.0:
            return math.inf
        return now + float(self._draws.exponential(self.parameters.wander_mean_gap))

    def _wandering(self, now: float) -> Vector3:
        """The sum of the wander excursions running at ``now`` (each 0 -> peak -> 0 as 1 - cos over its duration)."""
        p = self.parameters
        draws = self._draws
        while draws is not None and self._next_wander <= now:
            heading = draws.uniform(0.0, 2.0 * math.pi)
            direction = np.array([math.cos(heading), math.sin(heading), float(draws.uniform(-0.5, 0.5))])
            direction /= float(np.linalg.norm(direction))
            self._wander.append((self._next_wander, float(draws.uniform(*p.wander_period_range)),
                                 float(draws.uniform(*p.wander_amplitude_range)) * direction))
            self._next_wander = self._draw_gap(self._next_wander)
        self._wander = [w for w in self._wander if now < w[0] + w[1]]
        total = np.zeros(3)
        for start, duration, peak in self._wander:
            if now >= start:
                total += 0.5 * (1.0 - math.cos(2.0 * math.pi * (now - start) / duration)) * peak
        return total

    # -- seeing ------------------------------------------------------------------------------------------------
    def see(self, arrival: float, frame: Frame) -> None:
        """A camera frame arrives (after the backward channel's delay)."""
        arrival = finite_scalar("arrival", arrival)
        self._frames.append((arrival, Frame(finite_scalar("stamp", frame.stamp),
                                            finite_array("tcp", frame.tcp, shape=(3,)).copy(),
                                            finite_array("pushable_obstacle", frame.pushable_obstacle,
                                                         shape=(3,)).copy())))

    def _perceive(self, now: float) -> None:
        """Take in the frames that arrived at least a reaction time ago."""
        p = self.parameters
        while self._frames and self._frames[0][0] <= now - p.reaction_time:
            arrival, frame = self._frames.popleft()
            capture = arrival - p.assumed_one_way_delay
            own_offset = self._target_at(capture - p.assumed_one_way_delay - p.handle_lag)
            planar = frame.tcp[:2] - own_offset[:2] - np.asarray(p.circle_centre)
            angle = math.atan2(planar[1], planar[0])
            if self._last_angle is not None:   # unwrap
                angle = self._last_angle + (angle - self._last_angle + math.pi) % (2.0 * math.pi) - math.pi
            self._last_angle = angle
            self._usable.append((capture, frame.stamp, angle))
            self._speed = None
            while self._usable and self._usable[0][1] < frame.stamp - p.estimation_window:
                self._usable.popleft()
            seen = frame.pushable_obstacle[:2] - np.asarray(p.circle_centre)
            self.pushable_on_path = abs(float(np.linalg.norm(seen)) - p.circle_radius) < p.on_path_distance

    def _angular_speed(self) -> float | None:
        """The median of the frame-to-frame angular speeds in the video's time (a jump in the seen pose is one
        outlier, not a new speed); computed once for each set of usable frames."""
        if self._speed is None:
            self._speed = (self._median_angular_speed(),)
        return self._speed[0]

    def _median_angular_speed(self) -> float | None:
        if len(self._usable) < 3 or self._usable[-1][1] - self._usable[0][1] < 0.5 * self.parameters.estimation_window:
            return None
        times, angles = np.array([u[1] for u in self._usable]), np.array([u[2] for u in self._usable])
        steps = np.diff(times)
        keep = steps > 1e-6
        if not keep.any():
            return None
        speed = float(np.median(np.diff(angles)[keep] / steps[keep]))
        return speed if abs(speed) >= self.parameters.min_angular_speed else None

    # -- acting ------------------------------------------------------------------------------------------------
    def _target_at(self, time: float) -> Vector3:
        """The hand target held at ``time`` (zero before the first)."""
        index = bisect_right(self._target_times, time) - 1
        return self._targets[index][1] if index >= 0 else np.zeros(3)

    def target(self, now: float) -> Vector3:
        """The hand target at ``now`` [m, handle coordinates = the replica's offset]."""
        now = finite_scalar("now", now)
        self._perceive(now)
        p = self.parameters
        aim = now + p.assumed_one_way_delay + p.handle_lag       # when a move made now shows at the replica
        speed = self._angular_speed()
        target = self._wandering(now)
        for move in self._moves:
            # This playing's draws: the profile's time runs 1/stretch as fast, shifted by ``shift``, scaled by
            # ``amplitude`` (all 1, 1, 0 without VARYING).
            amplitude, stretch, shift = self._variation[move.name]
            passing = self._latched.get(move.name)
            if passing is None and speed is not None and (move.name != "push" or self.pushable_on_path):
                capture, _, angle = self._usable[-1]
                period = 2.0 * math.pi / abs(speed)
                ahead = (move.angle - angle) / speed                  # [s] from the capture to a passing
                passing = capture + ahead + period * math.floor((aim - capture - ahead) / period + 0.5)
                sigma = (aim - passing - shift) / stretch
                fresh = passing - self._done.get(move.name, -math.inf) > 0.5 * period   # not the one just played
                if fresh and move.knots[0][0] < sigma < move.knots[-1][0]:
                    self._latched[move.name] = passing
                    self.moves_started.append((move.name, now, passing))
                else:
                    passing = None
            if passing is None:
                continue
            sigma = (aim - passing - shift) / stretch
            if sigma >= move.knots[-1][0]:
                self._done[move.name] = self._latched.pop(move.name)
                self._variation[move.name] = self._draw_variation()
                continue
            target = target + amplitude * _profile(sigma, move.knots) * move.direction
        self._targets.append((now, target))
        self._target_times.append(now)
        return target.copy()

