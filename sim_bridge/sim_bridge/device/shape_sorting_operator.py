"""A closed-loop virtual operator for the shape-sorting scene (paper E2): it looks, aligns and feels through the delay.

The scripted E2 operator (operator_scripts.shape_sorting_script) plays travel legs and contact moves timed in
advance against one run: which pieces end inside changes with a tenth of a second of its timing. This operator
plays the same kinds of moves but decides each one from what it sees and feels, as the paper's operator did
watching two cameras and holding the handle:

- SEEING: ``see(arrival, frame)`` hands it a camera frame -- the replica's TCP and every piece's position at
  capture -- when it arrives, after the backward channel's delay (the video shares the link with the force
  feedback). A frame is used ``perception_delay`` after it arrived: 0.25 s, the simple visual reaction time of the
  Model Human Processor (perceptual 100 ms + cognitive 70 ms + motor 70 ms; Card, Moran and Newell 1983, "The
  Psychology of Human-Computer Interaction", ch. 2), within the 0.19-0.25 s measured for a visual onset
  (Kosinski 2008, "A literature review on reaction time", Clemson University). The holes do not move: their
  positions are the scene's.
- MOVE AND WAIT: under a delay people stop making continuous corrections and move in steps, each a ballistic move
  followed by a wait until its result is seen (Ferrell 1965, "Remote manipulation with transmission delay", IEEE
  Trans. Human Factors in Electronics 6:24-32; Sheridan 1993, "Space teleoperation through time delay: review and
  prognosis", IEEE Trans. Robotics and Automation 9:592-606). Each step here aims at the whole error it saw; its
  result is judged once a frame captured after the replica got the move has been perceived: two one-way delays
  (``assumed_one_way_delay``, the latency the expert has learnt), a ``settle`` time and the perception delay.
  Steps repeat until the error is inside a tolerance, at most ``max_corrections`` times a goal.
- TRAVEL in the master's VELOCITY mode (the handle's 0.19 x 0.13 m cannot span the table): one handle excursion a
  step, of area travel / k_v beyond the master's dead-band (docs/CONTROL_LAWS.md). CONTACT work in OFFSET mode with
  s_M = 1, the handle back at its origin at every mode switch (button 0), as the script does.
- FEELING: ``feel(force, handle)`` at the device's rate with the force the motors render on the handle (paper Eq. 3:
  the handle's own FIC plus K_H times the delayed F_R). The operator has learnt the handle's own centring spring by
  practice (people learn an internal model of a force field they move in: Shadmehr and Mussa-Ivaldi 1994, "Adaptive
  representation of dynamics during learning of a motor task", J. Neurosci. 14:3208-3224) and feels as contact what
  is beyond it: ``learnt_stiffness`` toward the origin, bounded by ``learnt_max_force`` (the master's K0 and F_max).
  A contact counts when that exceeds ``touch_force`` (1 N: about 25 % of the 4 N the handle's own spring can reach,
  well above the 7-10 % just-noticeable difference of a held force, Jones 1989, "Matching forces: constant errors
  and differential thresholds", Perception 18:681-687, and the model's own error).
- PHASES per piece: reach (travel to hover over the piece as seen), grasp (align over it as seen, press until the
  contact is felt, hold ``bond_time`` so the adhesive bond forms, lift; the bond is judged by seeing the piece rise),
  carry (travel to above its hole with the piece as seen), align (offset-mode steps until the piece's seen centre is
  within ``align_tolerance`` of the hole's), descend (the piece's bottom ``entry_depth`` into the lid: a light press,
  below the bond's weakest break force), search (if the piece is seen resting on the rim and the press is felt, a
  spiral about the aligned point until the felt contact gives way: the piece dropped into the hole), insert (to
  ``insert_margin`` below the rim), lock (sideways under the rim), pull (up until the felt pull gives way: the bond
  broke, or ``pull_time``), check (seen: the piece inside the box). A failed insertion lifts, re-aligns and tries
  again, at most ``max_insert_attempts`` times; a bond that held through a pull is yanked on the next attempt (the
  lock and the pull faster, the lock toward the other wall); a piece left outside the box (dropped, or on the lid)
  is picked again from where it is seen, at most ``max_piece_attempts`` times (one still on the plate is not).

``moves_started`` logs every phase as (``"<piece>:<phase>"``, start time, a figure: the attempt, the seen error or
the felt force), for the traces of docs/EXPERIMENTS.md "E2". Nothing here is timed in advance: the same policy runs at
any delay (told the latency it has learnt).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Iterator, NamedTuple

import numpy as np
from numpy.typing import NDArray

from fic_core.errors import FicInputError, finite_array, finite_scalar
from sim_bridge.device.virtual_operator import BUTTON_TOGGLE_MODE, ScriptEvent
from sim_bridge.robot.scenes import (
    PIECE_HEIGHT,
    SHAPE_SORTING_PIECES,
    SORTER_CENTRE_XY,
    SORTER_HALF_SIZE_XY,
    SORTER_PLATE_THICKNESS,
    SORTER_TOP_HEIGHT,
    SORTER_WALL_THICKNESS,
    TABLE_TOP_HEIGHT,
)

Vector3 = NDArray[np.float64]

#: [s] simulated length of one E2 trial with this operator, wherever E2 runs (the graph, the in-process runner, the
#: paper's experiments): three pieces at 41-43 s each (measured on the graph at 200 ms each way, docs/EXPERIMENTS.md
#: "E2") after a 4 s start, with room for a retry.
TRIAL_DURATION_S = 160.0


class SortingFrame(NamedTuple):
    """One camera frame, base frame [m]: the replica's TCP (the plate's lower face) and each piece's centre in the
    order of scenes.SHAPE_SORTING_PIECES, with the video's own capture stamp [s]."""

    stamp: float
    tcp: Vector3
    pieces: NDArray[np.float64]   # (n, 3)


@dataclass(frozen=True)
class ShapeSortingParameters:
    # Human figures (module docstring):
    perception_delay: float = 0.25        # [s] a frame is used this long after it arrived (Card et al. 1983)
    assumed_one_way_delay: float = 0.2    # [s] the latency the operator has learnt (runner: the cell's delay)
    touch_force: float = 1.0              # [N] felt beyond the learnt field: a contact (Jones 1989)
    learnt_stiffness: float = 100.0       # [N/m] the handle's own spring as learnt (config/master.yaml K0)
    learnt_max_force: float = 4.0         # [N] its bound (config/master.yaml F_max)
    # The master's velocity mode as the operator has learnt it (config/master.yaml):
    velocity_gain: float = 2.0            # k_v [1/s]
    velocity_deadband: float = 0.005      # [m]
    # Our choices (docs/EXPERIMENTS.md "E2"): speeds, waits, tolerances.
    travel_excursion: float = 0.05        # [m] handle excursion of a travel step (0.1 m/s at k_v = 2)
    ramp: float = 0.5                     # [s] the hand out to an excursion or between contact targets
    settle: float = 0.3                   # [s] after a step before its result is judged
    still_speed: float = 0.01             # [m/s] the seen TCP slower than this over still_window: at rest
    still_window: float = 0.3             # [s] of video
    max_still_wait: float = 1.5           # [s] longest extra wait for the seen TCP to come to rest
    travel_tolerance: float = 0.012       # [m] a travel step's goal is reached
    align_tolerance: float = 0.0015       # [m] piece centre to hole centre (half the 3 mm clearance per side)
    grasp_tolerance: float = 0.005        # [m] plate centre to piece centre before the press
    max_corrections: int = 6              # steps toward one goal
    hover: float = 0.03                   # [m] plate above the piece before the press
    press_depth: float = 0.03             # [m] commanded past the piece's top: K0 * 0.03 = 6 N > the bond's 3 N
    bond_time: float = 1.0                # [s] held pressed after the contact is felt
    clearance: float = 0.02               # [m] piece bottom above the lid while carrying
    entry_depth: float = 0.01             # [m] piece bottom commanded into the lid: K0 * 0.01 = 2 N on a rim
    search_radius: float = 0.007          # [m] spiral search's outer radius (beyond the 3 mm clearance)
    search_time: float = 4.0              # [s]
    search_turns: float = 2.0
    insert_margin: float = 0.005          # [m] plate commanded below the rim once the piece is in
    lock_shift: float = 0.06              # [m] sideways (x) push that jams the piece under the rim (the script's)
    pull: float = 0.06                    # [m] raise that pulls until the bond breaks (the script's)
    pull_time: float = 2.5                # [s] longest pull
    max_insert_attempts: int = 3
    max_piece_attempts: int = 3
    home_tolerance: float = 0.003         # [m] handle this near its origin before a mode switch
    handle_half_extents: tuple[float, float, float] = (0.095, 0.065, 0.065)   # [m] the device's workspace

    def __post_init__(self) -> None:
        for name in ("perception_delay", "assumed_one_way_delay", "settle", "velocity_deadband", "entry_depth",
                     "insert_margin", "search_radius", "hover", "clearance"):
            finite_scalar(name, getattr(self, name), minimum=0.0)
        for name in ("still_speed", "still_window", "max_still_wait", "touch_force", "learnt_stiffness",
                     "learnt_max_force", "velocity_gain", "travel_excursion",
                     "ramp", "travel_tolerance", "align_tolerance", "grasp_tolerance", "press_depth", "bond_time",
                     "search_time", "search_turns", "lock_shift", "pull", "pull_time", "home_tolerance"):
            finite_scalar(name, getattr(self, name), minimum=0.0, minimum_inclusive=False)
        for name in ("max_corrections", "max_insert_attempts", "max_piece_attempts"):
            if int(getattr(self, name)) < 1:
                raise FicInputError(f"{name} must be at least 1, got {getattr(self, name)}")
        extents = finite_array("handle_half_extents", self.handle_half_extents, shape=(3,))
        if np.any(extents <= 0.0):
            raise FicInputError(f"handle_half_extents must be positive, got {self.handle_half_extents}")
        if self.travel_excursion <= self.velocity_deadband:
            raise FicInputError("travel_excursion must exceed velocity_deadband")


def _smooth(fraction: float) -> float:
    """Quintic smoothstep: a minimum-jerk move between points of rest."""
    u = min(max(fraction, 0.0), 1.0)
    return u ** 3 * (10.0 - 15.0 * u + 6.0 * u ** 2)


_RAMP_SAMPLES = (np.arange(400) + 0.5) / 400
_RAMP_SHAPE = _RAMP_SAMPLES ** 3 * (10.0 - 15.0 * _RAMP_SAMPLES + 6.0 * _RAMP_SAMPLES ** 2)


def _ramp_area(excursion: float, deadband: float, ramp: float) -> float:
    """Integral over one smoothstep ramp (0 -> excursion in ``ramp`` s) of max(0, x - deadband) [m s]."""
    return float(ramp * np.mean(np.maximum(0.0, excursion * _RAMP_SHAPE - deadband)))


def velocity_step(travel: float, excursion: float, deadband: float, gain: float,
                  ramp: float) -> tuple[float, float]:
    """The handle excursion [m] and its hold [s] that move x_d' by ``travel`` [m] in VELOCITY mode: the master
    integrates k_v (|x_M| - deadband) along x_M, so the excursion's area beyond the dead-band is travel / k_v
    (ramp out, hold, ramp back). A short travel is a smaller excursion without a hold."""
    area = travel / gain
    hold = (area - 2.0 * _ramp_area(excursion, deadband, ramp)) / (excursion - deadband)
    if hold >= 0.0:
        return excursion, hold
    low, high = deadband, excursion
    for _ in range(40):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if 2.0 * _ramp_area(middle, deadband, ramp) < area else (low, middle)
    return 0.5 * (low + high), 0.0


def inside_box(position: NDArray[np.float64]) -> bool:
    """A piece's centre inside the sorting box: within the inner walls, under the lid, above the table (as
    experiments.shape_sorting.inside_box judges the outcome; here it is what the operator sees)."""
    x, y, z = (float(v) for v in position)
    return (abs(x - SORTER_CENTRE_XY[0]) < SORTER_HALF_SIZE_XY[0] - SORTER_WALL_THICKNESS
            and abs(y - SORTER_CENTRE_XY[1]) < SORTER_HALF_SIZE_XY[1] - SORTER_WALL_THICKNESS
            and TABLE_TOP_HEIGHT < z < SORTER_TOP_HEIGHT - SORTER_PLATE_THICKNESS)


class ShapeSortingOperator:
    """Hand targets and button presses from delayed frames and the felt force (module docstring). Call ``see`` as
    frames arrive, ``feel`` and then ``target`` at the device's rate and ``poll_events`` for the buttons, all on
    one clock."""

    def __init__(self, parameters: ShapeSortingParameters | None = None) -> None:
        self.parameters = parameters if parameters is not None else ShapeSortingParameters()
        self._now = 0.0
        self._hand = np.zeros(3)
        self._handle = np.zeros(3)
        self._contact = np.zeros(3)        # felt beyond the learnt field [N]
        self._frames: deque[tuple[float, SortingFrame]] = deque()
        self.seen: SortingFrame | None = None
        self._seen_track: deque[tuple[float, Vector3]] = deque()   # (stamp, TCP) of the perceived frames
        self._events: list[ScriptEvent] = []
        self._velocity_mode = False        # the master starts in OFFSET mode (config/master.yaml)
        self.moves_started: list[tuple[str, float, float]] = []
        self.outcomes: dict[str, str] = {}   # piece -> "inside" | "gave up" (as seen)
        self.finished = False
        self._task = self._sort_all()

    # -- senses ------------------------------------------------------------------------------------------------
    def see(self, arrival: float, frame: SortingFrame) -> None:
        """A camera frame arrives (after the backward channel's delay)."""
        pieces = np.asarray(frame.pieces, dtype=float)
        if pieces.shape != (len(SHAPE_SORTING_PIECES), 3) or not np.all(np.isfinite(pieces)):
            raise FicInputError(f"frame pieces must be a finite ({len(SHAPE_SORTING_PIECES)}, 3) array")
        self._frames.append((finite_scalar("arrival", arrival),
                             SortingFrame(finite_scalar("stamp", frame.stamp),
                                          finite_array("tcp", frame.tcp, shape=(3,)).copy(), pieces.copy())))

    def feel(self, rendered_force: NDArray[np.float64], handle_position: NDArray[np.float64]) -> None:
        """The force the device's motors render on the handle and where the handle is (proprioception)."""
        force = finite_array("rendered_force", rendered_force, shape=(3,))
        self._handle = finite_array("handle_position", handle_position, shape=(3,)).copy()
        p = self.parameters
        learnt = -p.learnt_stiffness * self._handle
        norm = float(np.linalg.norm(learnt))
        if norm > p.learnt_max_force:
            learnt *= p.learnt_max_force / norm
        self._contact = force - learnt

    @property
    def felt_contact(self) -> NDArray[np.float64]:
        return self._contact.copy()

    def _perceive(self) -> None:
        p = self.parameters
        while self._frames and self._frames[0][0] <= self._now - p.perception_delay:
            self.seen = self._frames.popleft()[1]
            self._seen_track.append((self.seen.stamp, self.seen.tcp))
            while self._seen_track and self._seen_track[0][0] < self.seen.stamp - p.still_window:
                self._seen_track.popleft()

    def _seen_still(self) -> bool:
        """The seen TCP moved less than still_speed * still_window over the last still_window of video."""
        p = self.parameters
        if len(self._seen_track) < 2 or self._seen_track[-1][0] - self._seen_track[0][0] < 0.8 * p.still_window:
            return False
        points = np.array([tcp for _, tcp in self._seen_track])
        return bool(np.max(np.linalg.norm(points - points[-1], axis=1)) <= p.still_speed * p.still_window)

    # -- acting ------------------------------------------------------------------------------------------------
    def target(self, now: float) -> Vector3:
        """The hand target at ``now`` [m, handle coordinates]."""
        self._now = finite_scalar("now", now)
        self._perceive()
        if not self.finished:
            try:
                next(self._task)
            except StopIteration:
                self.finished = True
        limit = 0.9 * np.asarray(self.parameters.handle_half_extents)
        self._hand = np.clip(self._hand, -limit, limit)
        return self._hand.copy()

    def poll_events(self, now: float) -> list[ScriptEvent]:
        """Button presses made since the last poll."""
        events, self._events = self._events, []
        return events

    def _log(self, label: str, value: float = 0.0) -> None:
        self.moves_started.append((label, self._now, float(value)))

    # -- primitives (generators: one yield per device tick) --------------------------------------------------
    def _hold(self, duration: float) -> Iterator[None]:
        end = self._now + duration
        while self._now < end:
            yield

    def _hand_to(self, goal: NDArray[np.float64], duration: float) -> Iterator[None]:
        start, begin = self._hand.copy(), self._now
        goal = np.clip(np.asarray(goal, dtype=float), -0.9 * np.asarray(self.parameters.handle_half_extents),
                       0.9 * np.asarray(self.parameters.handle_half_extents))
        while self._now < begin + duration:
            self._hand = start + _smooth((self._now - begin) / duration) * (goal - start)
            yield
        self._hand = goal.copy()

    def _see_result(self) -> Iterator[None]:
        """Wait until a frame captured ``settle`` after the replica got what was done by now has been perceived."""
        p = self.parameters
        yield from self._hold(2.0 * p.assumed_one_way_delay + p.settle + p.perception_delay)
        end = self._now + p.max_still_wait
        while self._now < end and not self._seen_still():   # a ringing robot is judged once it is seen at rest
            yield

    def _home(self) -> Iterator[None]:
        """Hand back to the origin, and wait (at most 2 s) for the handle to be there."""
        yield from self._hand_to(np.zeros(3), self.parameters.ramp)
        end = self._now + 2.0
        while self._now < end and np.linalg.norm(self._handle) > self.parameters.home_tolerance:
            yield

    def _mode(self, velocity: bool) -> Iterator[None]:
        """Switch the master's mode with the handle at its origin (x_d' does not move)."""
        if self._velocity_mode == velocity:
            return
        yield from self._home()
        self._events.append(ScriptEvent(self._now, BUTTON_TOGGLE_MODE))
        self._velocity_mode = velocity
        yield from self._hold(0.1)

    def _velocity_travel(self, travel: NDArray[np.float64]) -> Iterator[None]:
        p = self.parameters
        distance = float(np.linalg.norm(travel))
        if distance < 1e-4:
            return
        direction = travel / distance
        with np.errstate(divide="ignore"):
            fits = float(np.min(np.where(np.abs(direction) > 1e-9,
                                         0.8 * np.asarray(p.handle_half_extents) / np.abs(direction), np.inf)))
        excursion, hold = velocity_step(distance, max(min(p.travel_excursion, fits), 1.5 * p.velocity_deadband),
                                        p.velocity_deadband, p.velocity_gain, p.ramp)
        yield from self._hand_to(excursion * direction, p.ramp)
        yield from self._hold(hold)
        yield from self._hand_to(np.zeros(3), p.ramp)

    def _travel(self, label: str, goal, tolerance: float) -> Iterator[None]:
        """Move-and-wait travel in VELOCITY mode until the seen TCP is within ``tolerance`` of ``goal(seen)``."""
        yield from self._mode(True)
        for _ in range(self.parameters.max_corrections):
            error = goal(self.seen) - self.seen.tcp
            self._log(f"{label}", float(np.linalg.norm(error)))
            if np.linalg.norm(error) <= tolerance:
                return
            yield from self._velocity_travel(error)
            yield from self._see_result()

    def _align(self, label: str, goal_xy, tolerance: float) -> Iterator[None]:
        """Move-and-wait in OFFSET mode: the hand shifts by the seen x-y error until it is within ``tolerance``."""
        yield from self._mode(False)
        for _ in range(self.parameters.max_corrections):
            error = goal_xy(self.seen)
            self._log(label, float(np.linalg.norm(error)))
            if np.linalg.norm(error) <= tolerance:
                return
            yield from self._hand_to(self._hand + np.array([error[0], error[1], 0.0]), 0.6 * self.parameters.ramp)
            yield from self._see_result()

    # -- the task ----------------------------------------------------------------------------------------------
    def _sort_all(self) -> Iterator[None]:
        while self.seen is None or not self._seen_still():   # the robot comes to its start point first
            yield
        for index, piece in enumerate(SHAPE_SORTING_PIECES):
            done = False
            for attempt in range(1, self.parameters.max_piece_attempts + 1):
                if not self._bonded(index):   # a piece still on the plate after failed insertions is not re-grasped
                    yield from self._grasp(index, attempt)
                if not self._bonded(index):
                    continue
                done = yield from self._insert(index)
                if done:
                    break
            self.outcomes[piece.shape] = "inside" if done else "gave up"
            self._log(f"{piece.shape}:{'done' if done else 'gave_up'}", 1.0 if done else 0.0)
        yield from self._mode(False)
        yield from self._home()

    def _bonded(self, index: int) -> bool:
        """Seen: the piece hangs under the plate (its top within 1 cm of the TCP, centres within 4 cm)."""
        seen = self.seen
        top = seen.pieces[index] + np.array([0.0, 0.0, PIECE_HEIGHT / 2])
        return bool(abs(top[2] - seen.tcp[2]) < 0.01 and np.linalg.norm(top[:2] - seen.tcp[:2]) < 0.04)

    def _grasp(self, index: int, attempt: int) -> Iterator[None]:
        p = self.parameters
        name = SHAPE_SORTING_PIECES[index].shape
        self._log(f"{name}:reach", attempt)
        travel_z = SORTER_TOP_HEIGHT + PIECE_HEIGHT + p.clearance

        def up(seen: SortingFrame) -> Vector3:
            return np.array([seen.tcp[0], seen.tcp[1], max(seen.tcp[2], travel_z)])

        def over(seen: SortingFrame) -> Vector3:
            return np.array([seen.pieces[index][0], seen.pieces[index][1], max(seen.tcp[2], travel_z)])

        def hover(seen: SortingFrame) -> Vector3:
            top = seen.pieces[index][2] + PIECE_HEIGHT / 2
            return np.array([seen.pieces[index][0], seen.pieces[index][1], top + p.hover])

        if self.seen.tcp[2] < travel_z - p.travel_tolerance:
            yield from self._travel(f"{name}:reach_up", up, p.travel_tolerance)
        yield from self._travel(f"{name}:reach_across", over, p.travel_tolerance)
        yield from self._travel(f"{name}:reach_down", hover, p.travel_tolerance)
        self._log(f"{name}:grasp", attempt)
        yield from self._align(f"{name}:grasp_align", lambda seen: seen.pieces[index][:2] - seen.tcp[:2],
                               p.grasp_tolerance)
        top = self.seen.pieces[index][2] + PIECE_HEIGHT / 2
        start = self._hand.copy()
        press = start + np.array([0.0, 0.0, top - self.seen.tcp[2] - p.press_depth])
        yield from self._hand_to(press, 2.0 * p.ramp)
        end = self._now + 2.0 * p.assumed_one_way_delay + 1.5
        while self._now < end and self._contact[2] < p.touch_force:
            yield
        self._log(f"{name}:press_felt", float(self._contact[2]))
        yield from self._hold(p.bond_time)
        self._log(f"{name}:lift", attempt)
        yield from self._hand_to(start, 2.0 * p.ramp)
        yield from self._see_result()

    def _insert(self, index: int) -> Iterator[None]:
        """Carry, align, insert, lock and pull; True when the piece is seen inside the box."""
        p = self.parameters
        piece = SHAPE_SORTING_PIECES[index]
        name = piece.shape
        hole = np.asarray(piece.hole_position, dtype=float)
        travel_z = SORTER_TOP_HEIGHT + PIECE_HEIGHT + p.clearance

        def up(seen: SortingFrame) -> Vector3:
            return np.array([seen.tcp[0], seen.tcp[1], max(seen.tcp[2], travel_z)])

        def above(seen: SortingFrame) -> Vector3:
            return np.array([seen.tcp[0] + hole[0] - seen.pieces[index][0],
                             seen.tcp[1] + hole[1] - seen.pieces[index][1], travel_z])

        for attempt in range(1, p.max_insert_attempts + 1):
            self._log(f"{name}:carry", attempt)
            if self.seen.tcp[2] < travel_z - p.travel_tolerance:
                yield from self._travel(f"{name}:carry_up", up, p.travel_tolerance)
            yield from self._travel(f"{name}:carry_across", above, 0.5 * p.travel_tolerance)
            if not self._bonded(index):
                self._log(f"{name}:dropped", attempt)
                return False
            yield from self._align(f"{name}:align", lambda seen: hole[:2] - seen.pieces[index][:2],
                                   p.align_tolerance)
            # Descend: the piece's bottom entry_depth into the lid (a light press if it rests on the rim).
            self._log(f"{name}:descend", attempt)
            anchor = self._hand.copy()
            bottom = self.seen.pieces[index][2] - PIECE_HEIGHT / 2
            entry = anchor + np.array([0.0, 0.0, (SORTER_TOP_HEIGHT - p.entry_depth) - bottom])
            yield from self._hand_to(entry, 2.0 * p.ramp)
            yield from self._see_result()
            bottom = self.seen.pieces[index][2] - PIECE_HEIGHT / 2
            if bottom > SORTER_TOP_HEIGHT - 0.5 * p.entry_depth and self._contact[2] >= p.touch_force:
                yield from self._search(name, entry)
            # Insert: the plate insert_margin below the rim (the plate is wider than every hole).
            self._log(f"{name}:insert", attempt)
            depth = (SORTER_TOP_HEIGHT - p.insert_margin) - self.seen.tcp[2]
            inserted = self._hand + np.array([0.0, 0.0, depth])
            yield from self._hand_to(inserted, 2.0 * p.ramp)
            yield from self._see_result()
            top = self.seen.pieces[index][2] + PIECE_HEIGHT / 2
            if top > SORTER_TOP_HEIGHT + 0.01:   # not through: lift, look again, retry
                self._log(f"{name}:insert_failed", float(top - SORTER_TOP_HEIGHT))
                yield from self._hand_to(anchor, 2.0 * p.ramp)
                yield from self._see_result()
                if not self._bonded(index):
                    self._log(f"{name}:dropped", attempt)
                    return False
                continue
            yield from self._lock_and_pull(name, inserted, attempt)
            yield from self._home()
            yield from self._see_result()
            if inside_box(self.seen.pieces[index]):
                return True
            if not self._bonded(index):
                self._log(f"{name}:lost", attempt)
                return False
        return False

    def _search(self, name: str, centre: NDArray[np.float64]) -> Iterator[None]:
        """Peg-in-hole by feel: a spiral about the aligned point at the light press until the press gives way."""
        p = self.parameters
        self._log(f"{name}:search", float(self._contact[2]))
        begin = self._now
        while self._now < begin + p.search_time:
            fraction = (self._now - begin) / p.search_time
            angle = 2.0 * math.pi * p.search_turns * fraction
            radius = p.search_radius * fraction
            self._hand = centre + np.array([radius * math.cos(angle), radius * math.sin(angle), 0.0])
            if self._contact[2] < 0.5 * p.touch_force and self._now - begin > 2.0 * p.assumed_one_way_delay:
                self._log(f"{name}:gave_way", float(self._contact[2]))
                return
            yield

    def _lock_and_pull(self, name: str, inserted: NDArray[np.float64], attempt: int) -> Iterator[None]:
        """Jam the piece against the hole's wall and pull. A bond that held through a pull is yanked on the next
        attempt: the lock and the pull made 1/attempt as long (faster, so the arm's momentum adds to the controller's
        bounded force when the piece catches), the lock toward the other wall."""
        p = self.parameters
        self._log(f"{name}:lock", float(self._contact[2]))
        side = 1.0 if attempt % 2 else -1.0
        locked = inserted + np.array([side * p.lock_shift, 0.0, 0.0])
        yield from self._hand_to(locked, 2.0 * p.ramp / attempt)
        yield from self._hold(0.5)
        self._log(f"{name}:pull", float(self._contact[2]))
        pulled = np.array([locked[0], locked[1], p.pull])
        yield from self._hand_to(pulled, 2.0 * p.ramp / attempt)
        end, strongest, released = self._now + p.pull_time, 0.0, None
        while self._now < end:
            felt = float(np.linalg.norm(self._contact))
            strongest = max(strongest, felt)
            if strongest > 2.0 * p.touch_force and felt < 0.5 * p.touch_force:
                released = released if released is not None else self._now
                if self._now - released > 0.1:
                    break
            else:
                released = None
            yield
        self._log(f"{name}:pulled", strongest)
        yield from self._hand_to(np.array([0.0, 0.0, p.pull]), 2.0 * p.ramp)
