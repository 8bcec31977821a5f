"""The replica watching its own loop: the age of the state it acts on, the gaps between its ticks and its commands.

Paper Eq. 7 is a law on the state (q, qd) of now. A replica starved of CPU computes it on a state tens of
milliseconds old, at irregular times, and the robot applies each torque until the next one: the damping terms of
the law (the FIC's twist error, the posture's -D qd, C(q, qd) qd) then act on a velocity the arm no longer has.
A starved two-station run swung the simulated arm over its base at up to 11 rad/s that way (docs/RESULTS.md,
"Starvation"). So the loop measures, at every control tick:

- the state age: the receiver's clock against the joint state's stamp, less the smallest such difference seen
  since the last long gap (``clock_offset``). A real driver stamps on the wall clock and lockstep on simulated time,
  where that offset is the transport's latency; a simulated robot that fell behind real time has stamps that lag the
  wall clock by however long it stalled, and a stall of the robot is a long gap for the replica (no states come),
  at which the offset is taken afresh; between gaps the offset may rise by CLOCK_DRIFT_ALLOWANCE of the time
  since the last tick (a robot that runs slower than real time without stalling). A replica whose states queue up
  behind a busy process sees them age against the offset of its healthy ticks: a latency that grows slower than
  the allowance goes unnoticed by this check (the tick gap still holds);
- the tick gap: the receiver's clock since the previous control tick, and the state gap: the arm's own clock (the
  joint states' stamps) between the states of two control ticks. They differ when the robot's clock does not
  keep the receiver's: a simulated robot that fell behind steps its backlog in a burst on the last torque
  (measured under a 40 % CPU quota: ticks at most 50 ms apart on the replica's clock whose states were 54-66 ms
  apart, one torque applied for up to 82 ms of the arm's time). The arm runs on one torque for the state gap,
  whatever the receiver saw, and the law on a sample-and-hold that long is what swung the wrist past its speed
  (docs/RESULTS.md, "Stress"): beyond max_tick_gap either way the loop holds;
- the command gap: the receiver's clock since the previous torque sent.

Beyond ``max_state_age`` or ``max_tick_gap`` the loop is unhealthy: the replica stops applying the law and holds,
sending the torque the robot's own stale-command watchdog applies (gravity, and joint damping on the state's
velocity, ``hold_torque``) on every tick whose state is fresh. On a stale state it sends the hold's gravity alone
once, as the hold begins (it replaces the law's last torque at the robot), and nothing after: a damper on a
velocity the arm had a tenth of a second ago pushes it wherever it was going, and gravity alone held for seconds
lets it float off (measured: 0.69 m in a 3 s starved window, docs/RESULTS.md "Starvation"); the robot's own
watchdog then holds the arm with gravity and damping on its own state, at its own rate. It resumes only after
``resume_ticks`` healthy ticks in a row, then blends the law in from the hold over ``resume_ramp`` seconds
(``law_fraction``), with the task controller started afresh (its convergent-phase latch and error memory belong to the
states before the hold). Every hold is counted, and the caller says it on /diagnostics.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_scalar

#: Joint damping of the hold [N m s/rad], per Panda joint: the simulated robot's stale-command hold's
#: (sim_bridge's mujoco_panda.HOLD_DAMPING), so a hold of the replica and one of the robot brake alike.
HOLD_DAMPING = (10.0, 10.0, 10.0, 10.0, 2.0, 2.0, 2.0)

HEALTHY, HOLDING, RESUMING = "healthy", "holding", "resuming"

#: How fast the clock offset may rise between ticks [s per s of the receiver's clock]: a simulated robot at a
#: real-time factor of 0.5 or more lets its stamps fall behind the wall clock at most this fast without a long gap
#: (measured: a two-station run on the loaded machine drifted into "state ages" of 329 ms without one). A state that
#: waited in a queue ages at once, by far more than this allowance of a tick or two.
CLOCK_DRIFT_ALLOWANCE = 0.5


@dataclass(frozen=True)
class LoopHealthBounds:
    """Where the replica's loop stops being trusted (docs/SECURITY.md, "The replica's own loop")."""

    max_state_age: float = 0.04    # [s] a law on an older state is not applied (below the robot's 50 ms watchdog)
    # [s] ticks further apart: the last torque held as long as the robot's watchdog allows
    max_tick_gap: float = 0.05
    resume_ticks: int = 25         # healthy control ticks in a row before the law comes back
    resume_ramp: float = 0.2       # [s] the law blended in from the hold over this long

    def __post_init__(self) -> None:
        finite_scalar("max_state_age", self.max_state_age, minimum=0.0, minimum_inclusive=False)
        finite_scalar("max_tick_gap", self.max_tick_gap, minimum=0.0, minimum_inclusive=False)
        finite_scalar("resume_ramp", self.resume_ramp, minimum=0.0)
        if int(self.resume_ticks) != self.resume_ticks or self.resume_ticks < 1:
            raise FicInputError(f"resume_ticks must be a whole number >= 1, got {self.resume_ticks}")


class LoopHealth:
    """Stepped by the replica loop at every control tick (``tick``) and every torque sent (``command_sent``)."""

    def __init__(self, bounds: LoopHealthBounds | None = None) -> None:
        self.bounds = LoopHealthBounds() if bounds is None else bounds
        self.state = HEALTHY
        self.state_age = 0.0            # [s] of the last tick
        self.tick_gap = 0.0             # [s] before the last tick
        self.command_gap = 0.0          # [s] before the last command
        self.max_state_age_seen = 0.0
        self.max_tick_gap_seen = 0.0
        self.state_gap = 0.0            # [s] between the states of the last two ticks (the arm's clock)
        self.max_state_gap_seen = 0.0
        self.max_command_gap_seen = 0.0
        self.holds = 0                  # transitions into the hold
        self.held_ticks = 0             # control ticks answered with the hold torque
        self.reason = ""                # why the last hold began
        self._last_tick: float | None = None
        self._last_command: float | None = None
        self._last_state_time: float | None = None
        self._healthy_run = 0
        self._resume_start: float | None = None
        self._entered_hold = False
        self.clock_offset: float | None = None   # [s] the smallest now - state_time since the last long gap
        self._age_known = False

    @property
    def holding(self) -> bool:
        return self.state == HOLDING

    def tick(self, now: float, state_time: float) -> str:
        """A control tick at ``now`` (the receiver's clock) on a joint state stamped ``state_time``. Returns "" or,
        once, the notice of a transition (into the hold, or back to the law)."""
        raw = now - state_time
        gap = 0.0 if self._last_tick is None else max(now - self._last_tick, 0.0)
        # The state gap from the last tick whose state was known to be fresh: one after an old state says how old
        # that was, which the age check has said already, and the first tick's state (or the first after a long
        # gap) may have waited in the reader's queue while the process started (measured: 54 ms at a run's start).
        state_gap = 0.0 if self._last_state_time is None else max(state_time - self._last_state_time, 0.0)
        self._last_tick = now
        if not (math.isfinite(raw) and math.isfinite(gap)):
            raw = gap = math.inf
        if not math.isfinite(state_gap):
            state_gap = math.inf
        # After a long gap the offset is taken afresh (module docstring), and this tick's state has no known age: a
        # robot that stalled and a state that waited in a starved replica's queue look alike until the next ticks.
        self._age_known = not (self.clock_offset is None or gap > self.bounds.max_tick_gap)
        if math.isfinite(raw) and (not self._age_known or raw < self.clock_offset):
            self.clock_offset = raw   # first state, after a long gap, or a lower latency
        elif math.isfinite(raw):
            # A robot running slower than real time without a long gap: its stamps drift behind the clock smoothly.
            self.clock_offset = min(raw, self.clock_offset + CLOCK_DRIFT_ALLOWANCE * gap)
        age = max(raw - self.clock_offset, 0.0) if math.isfinite(raw) else math.inf
        self.state_age, self.tick_gap = age, gap
        self.max_state_age_seen = max(self.max_state_age_seen, age)
        self.max_tick_gap_seen = max(self.max_tick_gap_seen, gap)
        self.state_gap = state_gap
        self.max_state_gap_seen = max(self.max_state_gap_seen, state_gap)
        bounds = self.bounds
        self._last_state_time = state_time if self._age_known and age <= bounds.max_state_age \
            and math.isfinite(state_time) else None
        self._entered_hold = False
        problems = []
        if age > bounds.max_state_age:
            problems.append(f"state {age * 1e3:.1f} ms old (bound {bounds.max_state_age * 1e3:g} ms)")
        if gap > bounds.max_tick_gap:
            problems.append(f"control ticks {gap * 1e3:.1f} ms apart (bound {bounds.max_tick_gap * 1e3:g} ms)")
        elif state_gap > bounds.max_tick_gap:
            problems.append(f"the states of two control ticks {state_gap * 1e3:.1f} ms apart on the arm's clock "
                            f"(bound {bounds.max_tick_gap * 1e3:g} ms)")
        if problems:
            self._healthy_run = 0
            self._resume_start = None
            if self.state != HOLDING:
                self.state = HOLDING
                self._entered_hold = True
                self.holds += 1
                self.reason = "; ".join(problems)
                return (f"replica loop unhealthy: {self.reason}; holding (gravity and joint damping) until "
                        f"{bounds.resume_ticks} healthy ticks")
            return ""
        if self.state == HOLDING:
            self._healthy_run += 1
            if self._healthy_run >= bounds.resume_ticks:
                self.state = RESUMING
                self._resume_start = now
                return (f"replica loop healthy for {self._healthy_run} ticks: the law takes over from the hold "
                        f"over {bounds.resume_ramp:g} s")
        elif self.state == RESUMING and self.law_fraction(now) >= 1.0:
            self.state = HEALTHY
            self._resume_start = None
        return ""

    def ready(self, now: float, state_time: float) -> str:
        """The law's torque of this tick is ready at ``now``: if its state (``state_time``) has grown older than
        max_state_age meanwhile (a replica preempted inside its tick), the loop holds from here on. Returns the
        notice of that hold, or ""."""
        if self.clock_offset is None or self.state == HOLDING:
            return ""
        age = now - state_time - self.clock_offset
        if not age > self.bounds.max_state_age:   # NaN: not late
            return ""
        self.state_age = age
        self.max_state_age_seen = max(self.max_state_age_seen, age)
        self.state, self._entered_hold, self._healthy_run, self._resume_start = HOLDING, True, 0, None
        self._age_known = True
        self.holds += 1
        self.reason = (f"state {age * 1e3:.1f} ms old when its torque was ready "
                       f"(bound {self.bounds.max_state_age * 1e3:g} ms)")
        return (f"replica loop unhealthy: {self.reason}; holding (gravity and joint damping) until "
                f"{self.bounds.resume_ticks} healthy ticks")

    def law_fraction(self, now: float) -> float:
        """How much of the law's torque goes out at ``now`` (the rest is the hold's): 0 while holding, rising
        linearly to 1 over resume_ramp after a resume, 1 when healthy."""
        if self.state == HOLDING:
            return 0.0
        if self.state == HEALTHY or self._resume_start is None or self.bounds.resume_ramp == 0.0:
            return 1.0
        return min(1.0, max(now - self._resume_start, 0.0) / self.bounds.resume_ramp)

    def resumed_at_this_tick(self, now: float) -> bool:
        """Whether the law came back at this tick (the caller starts the task controller afresh)."""
        return self.state == RESUMING and self._resume_start == now

    def held_tick(self) -> None:
        self.held_ticks += 1

    @property
    def state_fresh(self) -> bool:
        """Whether the last tick's state is known to be within max_state_age (its velocity is one the arm still
        has); not after a long gap, where its age is not known."""
        return self._age_known and self.state_age <= self.bounds.max_state_age

    def hold_command(self, gravity: ArrayLike, velocity: ArrayLike) -> NDArray[np.float64] | None:
        """What a held tick sends (module docstring): the hold torque on a fresh state; on a stale one gravity
        alone at the tick the hold began, else nothing (None: the robot's watchdog holds the arm)."""
        if self.state_fresh or self._entered_hold:
            return self.hold_torque(gravity, velocity, self.state_fresh)
        return None

    def command_sent(self, now: float) -> None:
        """A torque went out at ``now``."""
        gap = 0.0 if self._last_command is None else max(now - self._last_command, 0.0)
        self._last_command = now
        self.command_gap = gap
        self.max_command_gap_seen = max(self.max_command_gap_seen, gap)

    def hold_torque(self, gravity: ArrayLike, velocity: ArrayLike, fresh: bool) -> NDArray[np.float64]:
        """The stated hold: G(q) - D qd, as the robot's own watchdog holds the arm. The damping needs a velocity the
        arm still has: on a state not ``fresh`` (older than max_state_age, or of unknown age) it is left out (a
        damper on a stale velocity pushes wherever the arm was going, not against where it goes): gravity alone."""
        gravity = np.asarray(gravity, dtype=float)
        if not fresh:
            return gravity.copy()
        damping = np.asarray(HOLD_DAMPING[:gravity.size], dtype=float)
        return gravity - damping * np.asarray(velocity, dtype=float)

    def diagnostic_values(self) -> dict[str, str]:
        """The keys of the "replica loop health" status (docs/SECURITY.md)."""
        return {"state": self.state,
                "state_age_ms": f"{self.state_age * 1e3:.1f}",
                "clock_offset_ms": "none" if self.clock_offset is None else f"{self.clock_offset * 1e3:.1f}",
                "tick_gap_ms": f"{self.tick_gap * 1e3:.1f}",
                "command_gap_ms": f"{self.command_gap * 1e3:.1f}",
                "max_state_age_ms": f"{self.max_state_age_seen * 1e3:.1f}",
                "max_tick_gap_ms": f"{self.max_tick_gap_seen * 1e3:.1f}",
                "max_state_gap_ms": f"{self.max_state_gap_seen * 1e3:.1f}",
                "max_command_gap_ms": f"{self.max_command_gap_seen * 1e3:.1f}",
                "holds": str(self.holds),
                "held_ticks": str(self.held_ticks),
                "last_hold_reason": self.reason or "none"}
