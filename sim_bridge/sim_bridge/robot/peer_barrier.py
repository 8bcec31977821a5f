"""Lockstep for the nodes that do not answer each step: the operator's side of the graph.

In lockstep the simulation waits for the replica's answer to every joint state (stepping.LockstepGate), but the
haptic device, the master and the planner only follow ``/clock``. On a loaded machine they can fall behind it
(each gets the CPU in chunks while the simulation steps on), and the replica then receives x_d' tens of
milliseconds of simulated time late: the run depends on the machine's scheduling, not only on its seed. (The
bursts of commands with one stamp seen in lockstep bags had another cause, the EventsExecutor's timers under
simulated time; the nodes now spin the wait-set executor there.)

``PeerBarrier`` closes that gap. Each peer is a header-stamped topic of such a node; the simulation does not step
past ``t`` until every peer's newest stamp is at least ``t - max_lag`` (``max_lag`` covers the peer's own period:
a 100 Hz publisher is up to 10 ms behind by design). A peer is waited for once it has published, or once it is
``expect``-ed: the robot node does not take its first lockstep step before its subscription to every peer topic
has matched that peer's publisher, and then expects each peer at the start time. A peer that only follows /clock
cannot publish before the simulation moves, so an expected peer counts as stamped at the start: the simulation
goes at most ``max_lag`` past it until the peer's first message comes. (Waiting only for peers that had
published let a device whose first message the robot had not yet subscribed to fall 99 ms behind at the start of
a loaded run.) A peer that keeps
the simulation waiting longer than ``timeout`` (wall clock) is declared stalled (a dead or hung node) and is not
waited for again until it catches up, so a lost peer costs one timeout, not one per step.

Plain Python (threading only): the stamps come from the subscriber's thread, the waits from the physics thread.
"""
from __future__ import annotations

import threading
import time
from typing import Callable, Iterable

from fic_core.errors import FicInputError, finite_scalar


class PeerBarrier:
    """Holds the simulation's step until the peers' stamps have caught up (module docstring)."""

    def __init__(self, topics: Iterable[str], max_lag: float, timeout: float,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.topics = tuple(topics)
        if len(set(self.topics)) != len(self.topics) or any(not t for t in self.topics):
            raise FicInputError(f"peer topics must be distinct and non-empty, got {list(self.topics)}")
        self.max_lag = finite_scalar("max_lag", max_lag, minimum=0.0)
        self.timeout = finite_scalar("timeout", timeout, minimum=0.0, minimum_inclusive=False)
        self._clock = clock
        self._condition = threading.Condition()
        self._newest: dict[str, float] = {}   # topic -> newest stamp seen [s]
        self._stalled: set[str] = set()
        self._interrupted = False
        self.waits = 0          # steps that had to wait for a peer
        self.wait_time = 0.0    # wall time spent waiting [s]
        self.stalls = 0         # times a peer was declared stalled

    def stamp(self, topic: str, stamp: float) -> None:
        """A message of ``topic`` stamped ``stamp`` [s] arrived (subscriber's thread)."""
        with self._condition:
            if stamp > self._newest.get(topic, float("-inf")):
                self._newest[topic] = stamp
            self._condition.notify_all()

    def expect(self, topic: str, time_s: float) -> None:
        """``topic``'s peer is there (its publisher matched): wait for it from ``time_s`` [s] on, as if it had
        published a stamp ``time_s``; a stamp it did publish is kept."""
        if topic not in self.topics:
            raise FicInputError(f"{topic} is not one of the peers {list(self.topics)}")
        with self._condition:
            self._newest.setdefault(topic, time_s)
            self._condition.notify_all()

    def _behind(self, time_s: float) -> list[str]:
        bound = time_s - self.max_lag
        return [topic for topic, newest in self._newest.items()
                if newest < bound and topic not in self._stalled]

    def wait(self, time_s: float) -> list[str]:
        """Block (physics thread) until every live peer's newest stamp is at least ``time_s - max_lag``; returns
        the peers declared stalled by this wait (empty if none). Peers that caught up leave the stalled set."""
        with self._condition:
            bound = time_s - self.max_lag
            self._stalled = {topic for topic in self._stalled if self._newest[topic] < bound}
            if not self._behind(time_s) or self._interrupted:
                return []
            self.waits += 1
            start = self._clock()
            deadline = start + self.timeout
            while True:
                behind = self._behind(time_s)
                if not behind or self._interrupted:
                    self.wait_time += self._clock() - start
                    return []
                remaining = deadline - self._clock()
                if remaining <= 0.0:
                    self._stalled.update(behind)
                    self.stalls += len(behind)
                    self.wait_time += self._clock() - start
                    return behind
                self._condition.wait(remaining)

    @property
    def stalled(self) -> tuple[str, ...]:
        with self._condition:
            return tuple(sorted(self._stalled))

    def newest(self, topic: str) -> float | None:
        with self._condition:
            return self._newest.get(topic)

    def interrupt(self) -> None:
        """Wake a waiting physics thread (shutdown); later waits return at once."""
        with self._condition:
            self._interrupted = True
            self._condition.notify_all()
