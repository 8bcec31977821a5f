"""Time keeping of the simulated robot: ``realtime`` (wall-clock paced) and ``lockstep`` (command-driven) modes.

- realtime: one physics step per period (1 ms) of the wall clock, like the Franka's 1 kHz torque interface. The
  torque applied is the last command received (zero-order hold), as a real robot does between packets. Each
  step's lateness (how long after its deadline it started) is measured: a loaded machine shows up here first.
- lockstep: the simulation publishes the state of step k, then advances only once the controller's answer to
  that state has arrived (counted in order, see LockstepGate), or after a timeout, which is counted. The simulation
  then runs as fast as the controller answers, deterministically, and /clock carries its time to every node.

Both are plain Python (threading only) so that a test or an in-process experiment can use them without ROS.
"""
from __future__ import annotations

import threading
import time
from collections import deque
from dataclasses import dataclass
from itertools import islice
from typing import Callable

import numpy as np

from fic_core.errors import finite_scalar

STEPPING_MODES: tuple[str, ...] = ("realtime", "lockstep")


@dataclass(frozen=True)
class LatenessSummary:
    count: int
    p50: float  # [s]
    p99: float  # [s]
    max: float  # [s]
    achieved_rate: float  # [Hz] steps per wall-clock second over the window
    overruns: int  # times the loop fell so far behind that it dropped the missed deadlines (total)


class RealtimePacer:
    """Sleeps until each step's deadline on a fixed grid (start + k * period) and records the lateness.

    A grid (not "sleep one period after the last step") keeps the mean rate exact when single steps run late.
    When the loop falls more than ``max_backlog`` behind (a stall), the grid restarts from now: catching up by
    running many steps back-to-back would replay the hold command as a burst of simulated time.
    """

    def __init__(self, period: float = 0.001, window: int = 10000, max_backlog: float = 0.05,
                 clock: Callable[[], float] = time.monotonic, sleep: Callable[[float], None] = time.sleep) -> None:
        self._period = finite_scalar("period", period, minimum=0.0, minimum_inclusive=False)
        self._max_backlog = finite_scalar("max_backlog", max_backlog, minimum=0.0)
        self._clock = clock
        self._sleep = sleep
        self._lateness: deque[float] = deque(maxlen=window)
        self._step_times: deque[float] = deque(maxlen=window)
        self._start: float | None = None
        self._index = 0
        self.overruns = 0

    def wait_next(self) -> float:
        """Block until the next step is due; return its lateness [s] (>= 0 up to the sleep's precision)."""
        now = self._clock()
        if self._start is None:
            self._start = now
            self._index = 0
        deadline = self._start + self._index * self._period
        if now - deadline > self._max_backlog:
            self.overruns += 1
            self._start, self._index, deadline = now, 0, now
        elif deadline > now:
            self._sleep(deadline - now)
            now = self._clock()
        self._index += 1
        lateness = max(0.0, now - deadline)
        self._lateness.append(lateness)
        self._step_times.append(now)
        return lateness

    def recent_max(self, steps: int) -> float:
        """Worst lateness over the last ``steps`` steps [s] (0 before any)."""
        return max(islice(reversed(self._lateness), steps), default=0.0)

    def summary(self) -> LatenessSummary:
        if not self._lateness:
            return LatenessSummary(0, 0.0, 0.0, 0.0, 0.0, self.overruns)
        lateness = np.fromiter(self._lateness, dtype=float)
        span = self._step_times[-1] - self._step_times[0]
        rate = (len(self._step_times) - 1) / span if span > 0 else 0.0
        return LatenessSummary(len(lateness), float(np.percentile(lateness, 50)), float(np.percentile(lateness, 99)),
                               float(lateness.max()), rate, self.overruns)


class LockstepGate:
    """Hands the command for each published state from the subscriber's thread to the simulation thread.

    A command that names the joint state it was computed on (fic_core.command_stamp: the replica's do) is matched
    to the states by that stamp: the step is released when a command computed on the newest published state has
    arrived, and a command on an older state is a late answer (applied in place of an older one, never taken for
    the newest state's). The replica reads its joint states newest-only, so after a step it was late for it may
    never see that state and answer the next one at once; counting would take that prompt answer for the missed
    state's late one, and stay one behind until a resync (the shape-sorting graph trials: 27 stale-command holds of
    the arm, at each of which the newest answer had been computed on a state 1-19 ms old, docs/EXPERIMENTS.md).
    A command without a stamp falls back to order: the n-th such command answers the n-th state published (FIFO);
    after a timeout the late answer to the skipped state is counted, not taken for the next state's.
    ``resync`` declares every published state answered: after draining a burst (start, resuming after a hold) or
    when the counts have drifted apart.
    """

    def __init__(self) -> None:
        self._condition = threading.Condition()
        self._published = 0
        self._delivered = 0
        self._published_stamp: int | None = None   # [ns] of the newest state published, when given
        self._answered_stamp: int | None = None    # [ns] the newest state a delivered command names
        self._latest: np.ndarray | None = None
        self._latest_state_ns: int | None = None   # the state the latest command names (None: it names none)
        self._interrupted = False
        self._polled = 0
        self.timeouts = 0
        self.answered_steps = 0
        self.late_answers = 0  # commands that answered an older state than the newest published

    def state_published(self, stamp_ns: int | None = None) -> None:
        """A state is about to be published (before it is: an instant answer must count), stamped ``stamp_ns``."""
        with self._condition:
            self._published += 1
            if stamp_ns is not None:
                self._published_stamp = stamp_ns

    def _answered(self) -> bool:
        if self._interrupted:
            return True
        if self._published_stamp is not None and self._answered_stamp is not None:
            return self._answered_stamp >= self._published_stamp
        return self._delivered >= self._published

    def deliver(self, command: np.ndarray, state_stamp_ns: int | None = None) -> None:
        """Called from the subscription callback with a validated command, and the stamp of the state it names."""
        with self._condition:
            self._delivered += 1
            if state_stamp_ns is None:
                self._latest, self._latest_state_ns = command, None
                if self._delivered < self._published:
                    self.late_answers += 1
            else:
                if self._published_stamp is None or state_stamp_ns < self._published_stamp:
                    self.late_answers += 1
                if self._answered_stamp is None or state_stamp_ns >= self._answered_stamp:
                    self._answered_stamp = state_stamp_ns   # older than one already delivered: not taken
                    self._latest, self._latest_state_ns = command, state_stamp_ns
            self._condition.notify_all()

    def wait(self, timeout: float, count_timeout: bool = True) -> tuple[np.ndarray | None, bool]:
        """Wait for the answer to the newest published state: (command, True); on timeout (latest, False).

        ``count_timeout=False`` for waits that are not a late controller (waiting for the first command)."""
        deadline = time.monotonic() + timeout
        with self._condition:
            while not self._answered():
                remaining = deadline - time.monotonic()
                if remaining <= 0.0:
                    self.timeouts += int(count_timeout)
                    self._polled = self._delivered  # poll_any reports only what comes after this wait
                    return self._latest, False
                self._condition.wait(remaining)
            self._polled = self._delivered
            if self._interrupted:
                return self._latest, False
            self.answered_steps += 1
            return self._latest, True

    def wait_quiet(self, quiet_time: float) -> np.ndarray | None:
        """Wait until no command has arrived for ``quiet_time``; return the latest (a burst is over)."""
        with self._condition:
            while True:
                seen = self._delivered
                self._condition.wait(quiet_time)
                if self._delivered == seen or self._interrupted:
                    return self._latest

    def latest_named(self) -> tuple[np.ndarray | None, int | None]:
        """(the latest command taken, the stamp [ns] of the state it names, None if it names none), as one pair."""
        with self._condition:
            return self._latest, self._latest_state_ns

    def poll_any(self) -> tuple[np.ndarray | None, bool]:
        """Non-blocking: (latest command, whether any command arrived since the last poll_any or wait)."""
        with self._condition:
            arrived = self._delivered != self._polled
            self._polled = self._delivered
            return self._latest, arrived

    def resync(self) -> None:
        with self._condition:
            self._delivered = self._published
            self._polled = self._delivered   # (stamped answers need no resync: each names its state)

    def interrupt(self) -> None:
        """Wake a waiting simulation thread (shutdown)."""
        with self._condition:
            self._interrupted = True
            self._condition.notify_all()


class LockstepCommand:
    """Lockstep: the command the arm gets, and the simulated time its watchdog counts that command's age from.

    A command that names its joint state (the replica's) is newest by that stamp: a late answer, to a state before
    the one just published, is still newer than the torque held so far, so it is applied; and its age is counted
    from its state, so the watchdog measures on the simulated clock how old the torque on the arm is, not whether
    the answers' count lines up with the states' (LockstepGate). One whose state is already older than the
    watchdog's bound does not end a hold. A command that names no state is the newest state's answer when the gate
    releases the step (``fresh``), as before stamps.
    """

    def __init__(self, gate: LockstepGate) -> None:
        self._gate = gate
        self.command: np.ndarray | None = None
        self.state_ns: int | None = None   # the state the applied command names (None: it names none)

    def take(self, command: np.ndarray | None, fresh: bool, now: float, holding: bool,
             timeout: float) -> float | None:
        """After the step's wait (its ``command``, ``fresh``) at simulated time ``now``, the watchdog ``holding``
        or not with its bound ``timeout``: the time the watchdog counts the age of a newly taken ``self.command``
        from (the caller releases the watchdog with it), None when nothing new is taken."""
        latest, named_ns = self._gate.latest_named()
        if named_ns is None:
            if not fresh:
                return None
            self.command, self.state_ns = command, None
            return now
        if self.state_ns is not None and named_ns <= self.state_ns:
            return None
        state_time = min(named_ns * 1e-9, now)
        if holding and now - state_time > timeout:
            return None
        self.command, self.state_ns = latest, named_ns
        return state_time


class ZeroOrderHold:
    """The last command and when it arrived, shared between the subscriber's thread and the stepping thread."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._command: np.ndarray | None = None
        self._arrival = float("-inf")
        self._count = 0

    def update(self, command: np.ndarray, arrival_time: float) -> None:
        with self._lock:
            self._command = command
            self._arrival = arrival_time
            self._count += 1

    def latest(self) -> tuple[np.ndarray | None, float, int]:
        """(command or None, arrival time, number of commands so far): the count tells a new command from old."""
        with self._lock:
            return self._command, self._arrival, self._count
