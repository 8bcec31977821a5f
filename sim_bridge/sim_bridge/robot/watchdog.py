"""Command-staleness watchdog of the robot: hold the arm when the controller goes quiet, and say so once.

When the last valid torque command is older than ``timeout``, the robot stops replaying it (a zero-order hold of
a stale torque would push the arm on with no one watching) and applies the hold torque instead: gravity and
Coriolis compensation plus damping (PandaSimulation.hold_torque). It releases on the next fresh command. Each
transition is returned once as an event for the node to log and count; nothing is reported while the state holds.
The watchdog starts engaged: until the first command arrives the arm is held.

Time is whatever clock the caller passes: wall-clock seconds in realtime mode, simulation seconds in lockstep
(where a stalled controller stalls the simulation clock too, so staleness must be counted on that clock).
"""
from __future__ import annotations

from dataclasses import dataclass

from fic_core.errors import finite_scalar


@dataclass(frozen=True)
class WatchdogEvent:
    engaged: bool  # True: now holding; False: released
    time: float
    command_age: float  # [s] age of the newest command at the transition (inf before any command)
    message: str


class CommandWatchdog:
    def __init__(self, timeout: float) -> None:
        self._timeout = finite_scalar("command_timeout", timeout, minimum=0.0, minimum_inclusive=False)
        self._last_command_time: float | None = None
        self._holding = True
        self._reported_start = False
        self.engagements = 0  # transitions into hold after at least one command (the start does not count)

    @property
    def timeout(self) -> float:
        return self._timeout

    @timeout.setter
    def timeout(self, value: float) -> None:
        self._timeout = finite_scalar("command_timeout", value, minimum=0.0, minimum_inclusive=False)

    @property
    def holding(self) -> bool:
        return self._holding

    def command_age(self, now: float) -> float:
        return float("inf") if self._last_command_time is None else now - self._last_command_time

    def command_received(self, now: float) -> WatchdogEvent | None:
        """A valid command arrived at ``now``. Returns the release event if this ends a hold."""
        age = self.command_age(now)
        self._last_command_time = now
        if not self._holding:
            return None
        self._holding = False
        if age == float("inf"):
            return WatchdogEvent(False, now, age, "first torque command received: releasing the hold")
        return WatchdogEvent(False, now, age, f"torque commands resumed after {age:.3f} s: releasing the hold")

    def check(self, now: float) -> WatchdogEvent | None:
        """Call every step. Returns the engage event once when the commands go stale (or at start, before any)."""
        if self._holding:
            if not self._reported_start and self._last_command_time is None:
                self._reported_start = True
                return WatchdogEvent(True, now, float("inf"),
                                     "no torque command yet: holding the arm (gravity compensation + damping)")
            return None
        age = self.command_age(now)
        if age > self._timeout:
            self._holding = True
            self.engagements += 1
            return WatchdogEvent(True, now, age, f"torque commands stale ({age:.3f} s > {self._timeout:.3f} s): "
                                                 "holding the arm (gravity compensation + damping)")
        return None


class CommandStateAge:
    """The robot's rule on the state a torque was computed on (fic_core.command_stamp): a torque computed on a joint
    state older than ``timeout`` against the newest state the robot has published is never applied, and does not
    release the watchdog, so neither a starved controller's late torque nor the first one after a hold acts on an arm
    that has moved on (docs/SECURITY.md). Times in any one unit (robot_node: nanoseconds on its stamp grid; the
    in-process runner: simulated seconds); ``timeout`` may be infinite (no such rule)."""

    def __init__(self, timeout: float) -> None:
        self.timeout = timeout
        self.refused = 0   # torques refused so far

    def admits(self, state_time: float, newest_state_time: float) -> bool:
        """Whether a torque computed on the state of ``state_time`` may be applied (counted when not)."""
        if newest_state_time - state_time <= self.timeout:
            return True
        self.refused += 1
        return False
