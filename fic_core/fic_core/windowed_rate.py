"""The rate of a running total over a sliding time window: (S(t) - S(t - window)) / window.

What the channel's port observers report as "energy generated per second": their totals only grow or shrink by
what each tick books, and an average over the last window says whether the channel is generating energy now,
which the total (dominated by the past) cannot.
"""
from __future__ import annotations

import math
from collections import deque

from .errors import finite_scalar


class WindowedRate:
    """Samples (time, total) kept for ``window`` seconds; ``rate`` is the total's change over them per second."""

    def __init__(self, window: float) -> None:
        self.window = finite_scalar("window", window, minimum=1e-6)
        self._samples: deque[tuple[float, float]] = deque()

    def add(self, time: float, total: float) -> None:
        """One sample of the running total at ``time`` [s]; a sample older than the newest is ignored."""
        time, total = finite_scalar("time", time), finite_scalar("total", total)
        if self._samples and time < self._samples[-1][0]:
            return
        self._samples.append((time, total))
        # Keep one sample at or before the window's start, so the difference spans the whole window.
        while len(self._samples) > 1 and self._samples[1][0] <= time - self.window:
            self._samples.popleft()

    @property
    def rate(self) -> float:
        """(newest total - total at the window's start) / the time between them [unit/s]; 0 with fewer than two
        samples."""
        if len(self._samples) < 2:
            return 0.0
        (start, first), (end, last) = self._samples[0], self._samples[-1]
        span = end - start
        return (last - first) / span if span > 0.0 and math.isfinite(span) else 0.0
