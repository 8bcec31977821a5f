"""The harmonic trajectory planner (paper Eqs. 5 and 6, docs/CONTROL_LAWS.md): the autonomous part x_d'' of the command.

Per axis, with the next trajectory point x_t(t) and x~_t = x_t(t) - x_d''(t-1)::

    D:  a = sign(x~_t) * min(w_n^2 * |x~_t|, a_max) - mu*v                          (Eq. 5, D)
    C:  a = 2*A_max/x~_T0 * (x~_t - x~_T0/2) - mu*v                                 (Eq. 5, C; reading below)
    v = clip(integral a) ;  x_d'' = integral v                                         (Eq. 5)
    v_max = v_p * min(v_d, w_n*|d|) ,  a_max = 2*d*(v_max/|d|)^2 ,  v_p = 1.595 ,  mu = 0.01*w_n   (Eq. 6)

Reading of the C line (open in the paper). The printed ``2*A_max/x~_T0 * (x_d''(t-1) - x~_T0/2)`` mixes
an absolute position with a displacement. It is read as Eq. 2's mid-point law written on the error to the
target: ``x~_T0`` is the error x~_t latched when the axis enters C (the largest displacement of the D phase
that just ended) and ``A_max = min(w_n^2*|x~_T0|, a_max)`` is the D acceleration there, so the acceleration is
continuous at D->C. From rest at x~_T0 this is a harmonic swing about x~_T0/2 that arrives at x~_t = 0 with zero
velocity (and, with a_max binding, peaks at exactly v_max: that is why Eq. 6 has the factor 2). The phase
logic is the attractor's (Eq. 2): an axis enters C when |x~_t| decreases faster than ``rate_deadband``
(default 0: the planner's signal is noise-free), stays while it keeps decreasing on the same side of the
target, and returns to D otherwise. d|x~_t|/dt uses the target's velocity estimated by differencing x_t.

Choices made where the paper is silent:

* A "new command" is issued whenever x_t changes (by more than ``retarget_tolerance``): d, v_max and a_max are
  recomputed from the current x_d''. A fixed target issues one command; a moving target (the circle) one per
  step, so d is then the current lag and a_max scales with it.
* Velocity: the paper clips each axis to [-v_d, v_d]; v_d is the desired *tangential* velocity, so here the
  velocity vector's norm is clipped to v_d (stronger: it also bounds every axis). Because v_p > 1, long
  motions reach v_d before the harmonic peak, coast there, and stop short of the target; the axis then
  returns to D and converges in a second, smaller harmonic hop, so the target is never overshot.
* The total acceleration (including the viscous term) is clipped per axis to |a_max| of the current command,
  so |a| <= a_max always; the clip only ever reduces a deceleration below the undamped C law's, which
  lands exactly, so it cannot cause overshoot.
* Integration is semi-implicit Euler (velocity first), whose energy error on the C swing is O((w_n*dt)^2).
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.attractor import Phase
from fic_core.errors import FicInputError, finite_array, finite_scalar

#: v_p of paper Eq. 6.
VELOCITY_PEAK_RATIO = 1.595
#: mu = VISCOSITY_RATIO * w_n (paper, below Eq. 5).
VISCOSITY_RATIO = 0.01


class HarmonicPlanner:
    """Per-axis harmonic planner producing x_d'' (paper Eqs. 5-6)."""

    def __init__(self, natural_frequency: float, max_velocity: float, *, dimension: int = 3,
                 velocity_peak_ratio: float = VELOCITY_PEAK_RATIO, rate_deadband: float = 0.0,
                 retarget_tolerance: float = 1e-9) -> None:
        """
        Args:
            natural_frequency: w_n > 0 [rad/s].
            max_velocity: v_d > 0 [m/s], the desired tangential velocity and the speed limit.
            dimension: number of axes (3 for a position).
            velocity_peak_ratio: v_p of Eq. 6 (> 0).
            rate_deadband: dead-band on d|x~_t|/dt [m/s] for entering C.
            retarget_tolerance: a change of x_t larger than this [m] issues a new command.
        """
        self._natural_frequency = finite_scalar("natural_frequency", natural_frequency, minimum=0.0,
                                                minimum_inclusive=False)
        self._max_velocity = finite_scalar("max_velocity", max_velocity, minimum=0.0, minimum_inclusive=False)
        if isinstance(dimension, bool) or not isinstance(dimension, (int, np.integer)) or dimension < 1:
            raise FicInputError(f"dimension must be a positive integer, got {dimension!r}")
        self._dimension = int(dimension)
        self._velocity_peak_ratio = finite_scalar("velocity_peak_ratio", velocity_peak_ratio, minimum=0.0,
                                                  minimum_inclusive=False)
        self._rate_deadband = finite_scalar("rate_deadband", rate_deadband, minimum=0.0)
        self._retarget_tolerance = finite_scalar("retarget_tolerance", retarget_tolerance, minimum=0.0)
        self.reset(np.zeros(self._dimension))

    # --- parameters -------------------------------------------------------------------------------
    @property
    def natural_frequency(self) -> float:
        return self._natural_frequency

    @property
    def max_velocity(self) -> float:
        return self._max_velocity

    @property
    def viscosity(self) -> float:
        """mu = 0.01*w_n [1/s]."""
        return VISCOSITY_RATIO * self._natural_frequency

    @property
    def dimension(self) -> int:
        return self._dimension

    # --- state --------------------------------------------------------------------------------------
    def reset(self, position: ArrayLike) -> None:
        """Start at rest at ``position`` with no command."""
        self._position = finite_array("position", position, (self._dimension,)).copy()
        self._velocity = np.zeros(self._dimension)
        self._acceleration = np.zeros(self._dimension)
        self._in_convergence = np.zeros(self._dimension, dtype=bool)
        self._latched_displacement = np.zeros(self._dimension)  # x~_T0 per axis
        self._latched_acceleration = np.zeros(self._dimension)  # A_max per axis (magnitude)
        self._command_target: NDArray[np.float64] | None = None
        self._max_acceleration = np.zeros(self._dimension)  # |a_max| per axis of the current command
        self._previous_target: NDArray[np.float64] | None = None

    @property
    def position(self) -> NDArray[np.float64]:
        """x_d'' [m]."""
        return self._position.copy()

    @property
    def velocity(self) -> NDArray[np.float64]:
        return self._velocity.copy()

    @property
    def acceleration(self) -> NDArray[np.float64]:
        """The acceleration actually applied over the last step, (v_new - v_old)/dt."""
        return self._acceleration.copy()

    @property
    def max_acceleration(self) -> NDArray[np.float64]:
        """|a_max| per axis of the current command (Eq. 6)."""
        return self._max_acceleration.copy()

    @property
    def phase(self) -> NDArray[np.int64]:
        return np.where(self._in_convergence, int(Phase.CONVERGENCE), int(Phase.DIVERGENCE)).astype(np.int64)

    def command_limits(self, displacement: ArrayLike) -> tuple[float, NDArray[np.float64]]:
        """Eq. 6 for a command displacement d: (v_max, |a_max| per axis)."""
        displacement = finite_array("displacement", displacement, (self._dimension,))
        distance = float(np.linalg.norm(displacement))
        peak_velocity = self._velocity_peak_ratio * min(self._max_velocity, self._natural_frequency * distance)
        if distance == 0.0:
            return peak_velocity, np.zeros(self._dimension)
        return peak_velocity, 2.0 * np.abs(displacement) * (peak_velocity / distance) ** 2

    def step(self, target: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Advance by dt [s] toward the trajectory point x_t(t) = ``target``; returns x_d'' [m]."""
        target = finite_array("target", target, (self._dimension,))
        dt = finite_scalar("dt", dt, minimum=0.0, minimum_inclusive=False)
        if self._command_target is None or np.max(np.abs(target - self._command_target)) > self._retarget_tolerance:
            # A new command (Eq. 6): d is measured from the current x_d''.
            _, self._max_acceleration = self.command_limits(target - self._position)
            self._command_target = target.copy()
        target_velocity = (np.zeros(self._dimension) if self._previous_target is None
                           else (target - self._previous_target) / dt)
        self._previous_target = target.copy()

        error = target - self._position  # x~_t = x_t(t) - x_d''(t-1)
        magnitude_rate = np.sign(error) * (target_velocity - self._velocity)  # d|x~_t|/dt
        same_side = np.sign(error) == np.sign(self._latched_displacement)
        staying = self._in_convergence & (magnitude_rate < 0.0) & same_side
        entering = ~self._in_convergence & (magnitude_rate < -self._rate_deadband)
        if np.any(entering):
            self._latched_displacement[entering] = error[entering]
            # A_max: the D acceleration at the largest displacement of the D phase that just ended.
            self._latched_acceleration[entering] = np.minimum(
                self._natural_frequency ** 2 * np.abs(error[entering]), self._max_acceleration[entering])
        self._in_convergence = staying | entering

        viscous = self.viscosity * self._velocity
        divergence = (np.sign(error) * np.minimum(self._natural_frequency ** 2 * np.abs(error), self._max_acceleration)
                      - viscous)  # Eq. 5, D
        # 2*A_max/x~_T0 written as 2*min(w_n^2, a_max/|x~_T0|): no division by a tiny x~_T0 can blow up.
        safe_latched = np.where(self._latched_displacement != 0.0, np.abs(self._latched_displacement), 1.0)
        convergence_stiffness = 2.0 * np.minimum(self._natural_frequency ** 2,
                                                 self._latched_acceleration / safe_latched)
        convergence = convergence_stiffness * (error - 0.5 * self._latched_displacement) - viscous  # Eq. 5, C
        acceleration = np.where(self._in_convergence, convergence, divergence)
        acceleration = np.clip(acceleration, -self._max_acceleration, self._max_acceleration)

        velocity = self._velocity + acceleration * dt
        speed = float(np.linalg.norm(velocity))
        if speed > self._max_velocity:
            velocity = velocity * (self._max_velocity / speed)  # |v| <= v_d (Eq. 5's clip on the norm)
        self._acceleration = (velocity - self._velocity) / dt
        self._velocity = velocity
        self._position = self._position + velocity * dt
        return self._position.copy()

