"""A linear ramp from the last command to a rest command once an input stream goes stale.

What replaces the simulated robot's stale-command hold when a real driver stands in for it
(docs/HARDWARE.md, "Watchdogs"): a torque-controlled arm behind ros2_control's forward command controller keeps
applying the last command it received for as long as nobody sends another, and a Force Dimension device behind
forcedimension_ros2's effort controller does the same with the last force. So the node that computes those
commands watches its own input (the replica its joint states, the device adapter its handle pose and the master's
force) and, when it has been silent for ``timeout``, stops extrapolating a law from stale data: it publishes a
command that moves linearly, over ``ramp_time``, from the last command sent to a rest command (for the arm the
torque that holds it against gravity alone, fic_core.torque_semantics; for the device zero force), and holds
that. Fresh input ends the ramp; the law's next command is then rate-limited by the caller as usual.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_scalar


class StaleInputRamp:
    """Tracks one input stream's freshness and gives the ramp command while it is stale."""

    def __init__(self, timeout: float, ramp_time: float) -> None:
        self.timeout = finite_scalar("timeout", timeout, minimum=0.0, minimum_inclusive=False)
        self.ramp_time = finite_scalar("ramp_time", ramp_time, minimum=0.0)
        self._last_fresh: float | None = None
        self._stale_since: float | None = None
        self._start: NDArray[np.float64] | None = None
        self.engagements = 0

    @property
    def stale(self) -> bool:
        return self._stale_since is not None

    def fresh(self, now: float) -> bool:
        """A good input arrived at ``now``; True if this ends a stale period (say so once)."""
        self._last_fresh = now
        if self._stale_since is None:
            return False
        self._stale_since = None
        self._start = None
        return True

    def check(self, now: float, last_command: ArrayLike | None) -> bool:
        """Whether the stream is stale at ``now``; True once, at the moment it becomes stale (log it then).

        ``last_command`` is the command in force when it goes stale: the ramp starts from it. Before the first
        input nothing is stale (there is nothing to ramp from)."""
        if self._stale_since is not None or self._last_fresh is None or now - self._last_fresh <= self.timeout:
            return False
        self._stale_since = now
        self._start = None if last_command is None else np.array(last_command, dtype=float)
        self.engagements += 1
        return True

    def command(self, now: float, rest: ArrayLike) -> NDArray[np.float64]:
        """The ramp's command at ``now``: start + (rest - start) * min(1, elapsed / ramp_time)."""
        rest = np.asarray(rest, dtype=float)
        if self._stale_since is None:
            raise FicInputError("StaleInputRamp.command is only defined while the input is stale")
        if self._start is None or self._start.shape != rest.shape:
            return rest.copy()
        elapsed = max(now - self._stale_since, 0.0)
        fraction = 1.0 if self.ramp_time == 0.0 else min(1.0, elapsed / self.ramp_time)
        if not math.isfinite(fraction):
            fraction = 1.0
        return self._start + (rest - self._start) * fraction

    def silence(self, now: float) -> float | None:
        """Seconds since the last good input (None before the first)."""
        return None if self._last_fresh is None else now - self._last_fresh
