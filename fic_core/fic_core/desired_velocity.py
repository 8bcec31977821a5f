"""The desired TCP velocity fed to the FIC's error rate: x_d's difference quotient, low-pass filtered.

x_d moves in small steps as samples arrive and the holds advance, so its raw difference quotient is noisy; the
FIC's error rate d|e|/dt (paper Eq. 2's phase logic) is desired minus measured TCP velocity, and a first-order lag
of ``time_constant`` (backward Euler, exact for any tick interval dt) smooths the desired part. A time constant
of 0 disables it: the desired twist is then zero, as in the paper's law for a fixed set-point.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import finite_array, finite_scalar

_ZERO_ANGULAR = [0.0, 0.0, 0.0]  # the twist's angular part (the twist is always a new array)


class DesiredVelocityFilter:
    """Low-pass filtered velocity of the desired position, as a 6-D twist [v; 0] (module docstring)."""

    def __init__(self, time_constant: float = 0.02) -> None:
        self.time_constant = finite_scalar("time_constant", time_constant, minimum=0.0)
        self.reset()

    def reset(self) -> None:
        self._previous: NDArray[np.float64] | None = None
        self._velocity = np.zeros(3)

    @property
    def velocity(self) -> NDArray[np.float64]:
        """The filtered velocity [m/s] (3,), a copy."""
        return self._velocity.copy()

    def update(self, desired_position: ArrayLike, dt: float) -> NDArray[np.float64] | None:
        """The desired twist after x_d moved to ``desired_position`` in ``dt`` > 0 seconds; None while disabled
        and at the first call (no difference yet)."""
        position = finite_array("desired_position", desired_position, (3,))
        previous = self._previous
        self._previous = position
        if self.time_constant <= 0.0 or previous is None:
            return None
        dt = finite_scalar("dt", dt, minimum=0.0, minimum_inclusive=False)
        blend = dt / (self.time_constant + dt)
        # v + ((x_d - x_d,prev) / dt - v) * blend per axis on Python floats: the array form's operations in its
        # order (the same numbers), without numpy's per-call cost on 3-vectors at 1 kHz.
        velocity = [speed + ((now - before) / dt - speed) * blend
                    for now, before, speed in zip(position.tolist(), previous.tolist(), self._velocity.tolist())]
        self._velocity = np.array(velocity)
        return np.array(velocity + _ZERO_ANGULAR)
