"""The planner stepped on its own clock: x_d'' (paper Eqs. 5-6) sampled from a trajectory source at late or early
timer ticks without the ticks changing the planner's dynamics.

A late timer (a loaded machine, a slow simulated clock) hands the planner a long interval. One Euler step across it
would change the planner's dynamics, so the interval is integrated in steps no longer than the nominal period,
sampling the trajectory x_t(t) at each; a tick at the same or an earlier time (a clock that went back) moves nothing.
The trajectory's time is the clock's time since ``origin``, never negative.
"""
from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .planner import HarmonicPlanner


class TrajectorySource(Protocol):
    def point(self, t: float, position: ArrayLike | None = None) -> NDArray[np.float64]: ...


class PlannerSchedule:
    """Advances a HarmonicPlanner toward a TrajectorySource on the caller's clock (module docstring)."""

    def __init__(self, planner: HarmonicPlanner, source: TrajectorySource, origin: float,
                 nominal_period: float) -> None:
        if not nominal_period > 0.0:
            raise ValueError(f"nominal_period must be positive, got {nominal_period}")
        self.planner = planner
        self.source = source
        self.origin = origin                    # clock time of the trajectory's t = 0
        self.nominal_period = nominal_period
        self.target: NDArray[np.float64] = planner.position   # x_t at the last sample
        self._last_time: float | None = None

    def advance(self, now: float) -> NDArray[np.float64]:
        """Integrate the planner up to clock time ``now``; returns x_d''."""
        last = self._last_time
        if last is not None and now > last:
            elapsed = now - last
            steps = max(1, math.ceil(elapsed / self.nominal_period - 1e-9))
            # A tick on time integrates one nominal period: the clock's rounding of now - last (1e-16 s of a
            # floating clock) is not the planner's time, so a node and the in-process runner, whose clocks round
            # differently, step it alike.
            on_time = steps == 1 and abs(elapsed - self.nominal_period) <= 1e-9 * self.nominal_period
            step = self.nominal_period if on_time else elapsed / steps
            for k in range(1, steps + 1):
                # The last sample is at ``now`` itself (last + elapsed need not round to it).
                trajectory_time = max((now if k == steps else last + elapsed * k / steps) - self.origin, 0.0)
                self.target = self.source.point(trajectory_time, position=self.planner.position)
                self.planner.step(self.target, step)
        if last is None or now > last:
            self._last_time = now
        return self.planner.position

    def restart_trajectory(self, source: TrajectorySource, origin: float) -> None:
        """A new trajectory whose clock starts at ``origin``; the planner moves harmonically from where it is."""
        self.source, self.origin = source, origin

    def retune(self, planner: HarmonicPlanner) -> None:
        """A new planner (w_n, v_d), restarted at rest at the current position."""
        planner.reset(self.planner.position)
        self.planner = planner
