"""Homing: the device drives its handle to the centre x_M = 0 at a bounded speed before the handle is engaged
(beyond the paper; docs/TOOLS.md, "The operator's tools").

A bounded-speed attractor: the handle is asked to move at

    v_home = -(K / B) x_M ,  its norm bounded by homing_speed

and the device renders the damper that makes it, f = -B (v_M - v_home). Where the bound does not act this is the
spring-damper f = -K x_M - B v_M (K = 40 N/m and B = 10 N s/m on the simulated 0.5 kg handle: damping ratio 1.1,
no overshoot); farther out the pull is a damper toward a speed of homing_speed, so a handle resting at the edge of
the workspace is brought in at that speed instead of being flung at the centre by a spring. The handle is homed
once it is within homing_tolerance of the centre; the master engages it then (fic_core.master_station).

The damper is sampled at the master's control rate: B T / m < 2 keeps it stable (T the control period, m the
handle's mass; 10 x 0.004 / 0.5 = 0.08 here).
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .errors import finite_scalar
from .norm_bound import norm_bounded


class HandleHoming:
    """The bounded-speed attractor to x_M = 0 and the homed test (module docstring)."""

    def __init__(self, stiffness: float, damping: float, speed: float, tolerance: float) -> None:
        """
        Args:
            stiffness: K [N/m], the spring of the approach near the centre.
            damping: B [N s/m], the damper that sets the handle's speed.
            speed: the bound on the speed the handle is asked to move at [m/s].
            tolerance: the distance from the centre at which the handle is homed [m].
        """
        self.stiffness = finite_scalar("homing_stiffness", stiffness, minimum=0.0, minimum_inclusive=False)
        self.damping = finite_scalar("homing_damping", damping, minimum=0.0, minimum_inclusive=False)
        self.speed = finite_scalar("homing_speed", speed, minimum=0.0, minimum_inclusive=False)
        self.tolerance = finite_scalar("homing_tolerance", tolerance, minimum=0.0, minimum_inclusive=False)

    def force(self, handle_position: NDArray[np.float64], handle_velocity: NDArray[np.float64]) -> NDArray[np.float64]:
        """f [N] on the handle at x_M [m] moving at v_M [m/s] (finite, shape (3,): the station's own arrays)."""
        asked = norm_bounded(handle_position * (-self.stiffness / self.damping), self.speed)
        return (asked - handle_velocity) * self.damping

    def homed(self, handle_position: NDArray[np.float64]) -> bool:
        return math.sqrt(float(handle_position.dot(handle_position))) <= self.tolerance
