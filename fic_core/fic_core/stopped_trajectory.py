"""A trajectory whose clock stops: the source x_t(t) (fic_core.trajectories) up to ``stop``, then held at x_t(stop).

A run's quiet tail (docs/EXPERIMENTS.md, "The run verdict") stops the task: the harmonic planner (paper Eqs. 5-6)
keeps stepping toward the held point and brings x_d'' to rest on it at its own natural frequency (critically damped,
w_n = 8 rad/s in config/planner.yaml: within 1 % of its speed at the stop after about 0.8 s), so that the stop is not
a velocity step, which would itself be an input kicking the loop. After that x_d'' holds still.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.errors import FicInputError
from fic_core.planner_schedule import TrajectorySource


class StoppedTrajectory:
    """``source`` with its clock stopped at trajectory time ``stop`` [s] (module docstring)."""

    def __init__(self, source: TrajectorySource, stop: float) -> None:
        if not (math.isfinite(stop) and stop >= 0.0):
            raise FicInputError(f"stop must be a finite time >= 0 s, got {stop}")
        self.source = source
        self.stop = float(stop)

    def point(self, t: float, position: ArrayLike | None = None) -> NDArray[np.float64]:
        return self.source.point(min(t, self.stop), position)
