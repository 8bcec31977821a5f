"""The torque actually sent: the law's torque approached at the torque-rate limit, one command at a time.

The postural optimisation keeps each law output within rate x control_period of the torque sent before it, but
the torque goes out more often than the law runs when control_rate is below the joint-state rate (lockstep
answers every joint state) and the first command after a start or a change of controller has no rate bound.
Every command sent moves from the last one by at most ``torque_rate`` x the time since it (at least one command
period, never a faster step), per joint, so |tau_k - tau_(k-1)| <= torque_rate * dt_k holds for ANY sequence of
targets and times. A slewed torque lies between two torques inside the torque box, so it is inside it too.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import finite_array, finite_scalar


class TorqueSlew:
    """The sent torque, rate-limited toward a target (module docstring)."""

    def __init__(self, torque_rate: float, command_period: float) -> None:
        self.torque_rate = finite_scalar("torque_rate", torque_rate, minimum=0.0, minimum_inclusive=False)
        self.command_period = finite_scalar("command_period", command_period, minimum=0.0, minimum_inclusive=False)
        self._sent: NDArray[np.float64] | None = None
        self._time: float | None = None

    @property
    def last(self) -> NDArray[np.float64] | None:
        """The last torque sent (None before the first), read-only view."""
        return self._sent

    @property
    def last_time(self) -> float | None:
        return self._time

    def reset(self, torque: ArrayLike | None = None, time: float | None = None) -> None:
        """Forget the sent torque, or state the one now applied."""
        self._sent = None if torque is None else finite_array("torque", torque).copy()
        self._time = time

    def interval(self, time: float | None) -> float:
        """The time the next command may use for its step: since the last one, at least one command period
        (``time`` None: unknown, one command period)."""
        if time is not None and self._time is not None and time > self._time:
            return max(self.command_period, time - self._time)
        return self.command_period

    def step(self, target: NDArray[np.float64], time: float | None) -> NDArray[np.float64]:
        """The torque to send now toward ``target`` at ``time`` (the joint-state time it answers; None:
        unknown, one command period and the last time kept)."""
        previous = self._sent
        if previous is None:
            sent = np.array(target, dtype=float)
        else:
            step = self.torque_rate * self.interval(time)
            sent = previous + np.minimum(np.maximum(target - previous, -step), step)  # np.clip, without its dispatch
        self._sent = sent
        if time is not None:
            self._time = time
        return sent
