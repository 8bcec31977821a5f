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

_ZERO_ANGULAR = np.zeros(3)  # the twist's angular part (concatenate copies it: the twist is always a new array)


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
        raw = (position - previous) / dt
        self._velocity = self._velocity + (raw - self._velocity) * (dt / (self.time_constant + dt))
        return np.concatenate((self._velocity, _ZERO_ANGULAR))
