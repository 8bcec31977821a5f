"""The delay/dropout channel between master and replica (docs/CONVENTIONS.md), without any ROS in it.

A ``Channel`` holds opaque payloads (the node gives it raw CDR bytes, so it works for every message type) and
releases each one when it is due. What it can do to the traffic, each switchable at run time:

- a fixed one-way ``delay`` [s] (the paper's experiments: about 200 ms);
- bounded ``jitter`` [s]: the hold time is ``delay + u`` with ``u`` in ``[-jitter, +jitter]`` (uniform, or a
  normal with sigma = jitter/3 truncated at the bounds), never below zero;
- FIFO order by default: a message is never released before one pushed earlier (its due time is raised to its
  predecessor's), because a DDS stream over one link does not reorder; ``allow_reorder`` lifts this;
- ``drop_probability``: each message is lost independently with this probability;
- ``blackout_windows`` [(t0, t1), ...] and ``lost_from`` (the link is down for good from that time on, the
  paper's communication loss at about 280 s): a message is lost if the link is down when it is sent or when it
  would arrive;
- ``rate_cap_hz``: at most N deliveries per second, each delivery the newest message that is due, older due ones
  are superseded (the "10 Hz bandwidth" of arXiv 2003.01463: a slow link that samples the newest state);
- ``seed``: every random draw comes from one numpy Generator, so a run is reproducible message for message.

Times are floats in seconds on whatever clock the caller uses (wall or simulation); blackout windows and
``lost_from`` are on that same clock. The channel never reads a clock itself: the caller passes ``now``.

Cost: a push is one heap insertion and at most two random draws, a pop one heap removal per delivered message,
about 35 us a message with jitter and drops on this 2-core VM (numpy's scalar draws dominate), so 3.5 % of a
core at 1000 messages per second.
"""
from __future__ import annotations

import dataclasses
import heapq
import math
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from fic_core.errors import FicInputError, finite_scalar

JITTER_DISTRIBUTIONS = ("uniform", "normal")
DROP_CAUSES = ("random", "blackout", "lost", "rate_cap", "overflow")


@dataclass(frozen=True)
class ChannelConfig:
    """Everything that shapes the traffic. Immutable: reconfigure by giving the channel a new one."""

    delay: float = 0.0                              # fixed one-way delay [s]
    jitter: float = 0.0                             # bound on the deviation from ``delay`` [s]
    jitter_distribution: str = "uniform"            # "uniform" or "normal" (sigma = jitter/3, truncated)
    allow_reorder: bool = False                     # False keeps FIFO (a message waits for its predecessor)
    drop_probability: float = 0.0                   # independent loss probability per message
    blackout_windows: tuple[tuple[float, float], ...] = ()   # link down on [t0, t1) for each window
    lost_from: float | None = None                  # link down for good from this time on (None: never)
    rate_cap_hz: float = 0.0                        # at most this many deliveries a second (0: no cap)
    seed: int | None = None                         # seed of the random draws (None: from the OS)
    max_queue: int = 100_000                        # bound on held messages; the oldest is dropped beyond it

    def __post_init__(self) -> None:
        finite_scalar("delay", self.delay, minimum=0.0)
        finite_scalar("jitter", self.jitter, minimum=0.0)
        if self.jitter_distribution not in JITTER_DISTRIBUTIONS:
            raise FicInputError(
                f"jitter_distribution must be one of {JITTER_DISTRIBUTIONS}, got {self.jitter_distribution!r}")
        finite_scalar("drop_probability", self.drop_probability, minimum=0.0, maximum=1.0)
        windows = []
        for window in self.blackout_windows:
            if len(window) != 2:
                raise FicInputError(f"blackout_windows entries must be (t0, t1) pairs, got {window!r}")
            start = finite_scalar("blackout_windows t0", window[0])
            end = finite_scalar("blackout_windows t1", window[1])
            if end < start:
                raise FicInputError(f"blackout_windows: window ({start}, {end}) ends before it starts")
            windows.append((start, end))
        object.__setattr__(self, "blackout_windows", tuple(windows))
        if self.lost_from is not None:
            finite_scalar("lost_from", self.lost_from)
        finite_scalar("rate_cap_hz", self.rate_cap_hz, minimum=0.0)
        if self.seed is not None and (not isinstance(self.seed, (int, np.integer)) or self.seed < 0):
            raise FicInputError(f"seed must be a non-negative integer or None, got {self.seed!r}")
        if not isinstance(self.max_queue, (int, np.integer)) or self.max_queue < 1:
            raise FicInputError(f"max_queue must be a positive integer, got {self.max_queue!r}")

    def link_down(self, time: float) -> bool:
        """True if the link is down at ``time`` (inside a blackout window, or after ``lost_from``)."""
        if self.lost_from is not None and time >= self.lost_from:
            return True
        return any(start <= time < end for start, end in self.blackout_windows)


class Delivery(NamedTuple):
    """One message released by the channel."""

    payload: Any            # what was pushed, untouched (raw CDR bytes in the node)
    stamp: float | None     # the sender's stamp given at push [s], if any
    received_time: float    # when the channel received it [s]
    held: float             # how long the channel held it: release time - received_time [s]


@dataclass
class ChannelStatistics:
    """Counters and recent hold times. ``held_*`` are over the last ``window`` deliveries."""

    received: int = 0
    delivered: int = 0
    dropped: dict[str, int] = field(default_factory=lambda: {cause: 0 for cause in DROP_CAUSES})
    queue_size: int = 0
    held_p50: float = math.nan      # median hold time [s] (the delay the channel added)
    held_p99: float = math.nan
    held_max: float = math.nan
    age_p50: float = math.nan       # median age at release, release time - sender's stamp [s]
    age_p99: float = math.nan

    @property
    def dropped_total(self) -> int:
        return sum(self.dropped.values())


class _RingBuffer:
    """Fixed-size float history, so percentiles cost O(window) only when asked for, never per message."""

    def __init__(self, size: int) -> None:
        self._data = np.full(size, math.nan)
        self._next = 0
        self._count = 0

    def append(self, value: float) -> None:
        self._data[self._next] = value
        self._next = (self._next + 1) % self._data.size
        self._count = min(self._count + 1, self._data.size)

    def percentiles(self, *quantiles: float) -> list[float]:
        if self._count == 0:
            return [math.nan] * len(quantiles)
        values = self._data[: self._count] if self._count < self._data.size else self._data
        return [float(v) for v in np.percentile(values, quantiles)]


class Channel:
    """A one-way lossy, delaying link. ``push`` messages in, ``pop_due`` the ones that have arrived."""

    def __init__(self, config: ChannelConfig | None = None, statistics_window: int = 5000) -> None:
        self._config = config if config is not None else ChannelConfig()
        self._rng = np.random.default_rng(self._config.seed)
        # Heap of (due_time, sequence, payload, stamp, received_time). The sequence number breaks ties in push
        # order, so equal due times are released FIFO and payloads are never compared.
        self._queue: list[tuple[float, int, Any, float | None, float]] = []
        self._sequence = 0
        self._last_due = -math.inf          # due time of the newest queued message (for FIFO)
        self._next_slot = -math.inf         # earliest next delivery under the rate cap
        self._received = 0
        self._delivered = 0
        self._dropped = {cause: 0 for cause in DROP_CAUSES}
        self._held = _RingBuffer(statistics_window)
        self._age = _RingBuffer(statistics_window)

    @property
    def config(self) -> ChannelConfig:
        return self._config

    def reconfigure(self, config: ChannelConfig | None = None, **changes: Any) -> ChannelConfig:
        """Switch to a new configuration (a whole ``config``, or the named fields changed) at run time.

        Messages already held keep the due time they were given (a real link does not re-time packets in
        flight); the new delay, jitter and drop probability apply from the next push, the blackout and rate
        cap from the next pop. A new seed restarts the random stream. Invalid values raise FicInputError and
        leave the channel unchanged.
        """
        new_config = dataclasses.replace(config if config is not None else self._config, **changes)
        if new_config.seed != self._config.seed:
            self._rng = np.random.default_rng(new_config.seed)
        if new_config.rate_cap_hz != self._config.rate_cap_hz:
            self._next_slot = -math.inf
        self._config = new_config
        return new_config

    def push(self, payload: Any, stamp: float | None, now: float) -> bool:
        """Hand a message to the channel at time ``now``. Returns False if it was lost on the way in."""
        config = self._config
        self._received += 1
        if config.lost_from is not None and now >= config.lost_from:
            self._dropped["lost"] += 1
            return False
        if config.link_down(now):
            self._dropped["blackout"] += 1
            return False
        if config.drop_probability > 0.0 and self._rng.random() < config.drop_probability:
            self._dropped["random"] += 1
            return False
        due = now + self._hold_time(config)
        if not config.allow_reorder:
            due = max(due, self._last_due)
        self._last_due = max(self._last_due, due)
        heapq.heappush(self._queue, (due, self._sequence, payload, stamp, now))
        self._sequence += 1
        if len(self._queue) > config.max_queue:
            heapq.heappop(self._queue)      # the earliest-due one: the oldest in FIFO order
            self._dropped["overflow"] += 1
        return True

    def _hold_time(self, config: ChannelConfig) -> float:
        if config.jitter == 0.0:
            return config.delay
        if config.jitter_distribution == "uniform":
            deviation = self._rng.uniform(-config.jitter, config.jitter)
        else:
            # Truncated normal by rejection: at sigma = jitter/3 fewer than 0.3 % of draws are rejected.
            while True:
                deviation = self._rng.normal(0.0, config.jitter / 3.0)
                if abs(deviation) <= config.jitter:
                    break
        return max(0.0, config.delay + deviation)

    def pop_due(self, now: float) -> list[Delivery]:
        """Release every message due at ``now`` (oldest first), applying link outages and the rate cap."""
        config = self._config
        if config.rate_cap_hz > 0.0 and now < self._next_slot:
            # No delivery slot open: leave everything queued; at the next slot the newest due message wins.
            return []
        due: list[tuple[float, int, Any, float | None, float]] = []
        while self._queue and self._queue[0][0] <= now:
            entry = heapq.heappop(self._queue)
            # The link state that matters is the one at the moment the message would arrive, not the moment
            # somebody polled, so a late poll does not lose a message that arrived before an outage began.
            if config.lost_from is not None and entry[0] >= config.lost_from:
                self._dropped["lost"] += 1
            elif config.link_down(entry[0]):
                self._dropped["blackout"] += 1
            else:
                due.append(entry)
        if config.rate_cap_hz > 0.0 and due:
            self._dropped["rate_cap"] += len(due) - 1
            due = due[-1:]
            period = 1.0 / config.rate_cap_hz
            # Slots on a fixed grid keep the average rate at the cap despite a coarse polling timer (over any
            # interval T at most rate_cap_hz * T + 1 deliveries); after a quiet spell of more than a period the
            # grid restarts from now instead of bursting to catch up.
            self._next_slot += period
            if self._next_slot <= now:
                self._next_slot = now + period
        deliveries = []
        for _, _, payload, stamp, received_time in due:
            held = now - received_time
            self._held.append(held)
            if stamp is not None:
                self._age.append(now - stamp)
            deliveries.append(Delivery(payload, stamp, received_time, held))
        self._delivered += len(deliveries)
        return deliveries

    def next_due_time(self) -> float | None:
        """Due time of the earliest held message (None if empty), for a caller that schedules exactly."""
        return self._queue[0][0] if self._queue else None

    def __len__(self) -> int:
        return len(self._queue)

    def statistics(self) -> ChannelStatistics:
        held_p50, held_p99, held_max = self._held.percentiles(50, 99, 100)
        age_p50, age_p99 = self._age.percentiles(50, 99)
        return ChannelStatistics(received=self._received, delivered=self._delivered, dropped=dict(self._dropped),
                                 queue_size=len(self._queue), held_p50=held_p50, held_p99=held_p99,
                                 held_max=held_max, age_p50=age_p50, age_p99=age_p99)
