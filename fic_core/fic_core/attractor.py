"""The Fractal Impedance Controller's attractor (paper Eq. 2), per axis, with SPEC 1.2's reading.

Paper Eq. 2::

    D (divergence):  FIC(e) = F_c(e)
    C (convergence): FIC(e) = 2*F_c(e_max)/e_max * (e - e_max/2)

Reading implemented (SPEC 1.2; the printed switching condition, ``|e(t)| < |e(t-1)|`` *and* a sign change,
cannot hold together in one sample and is not used literally):

* An axis **enters C** when ``|e|`` is decreasing faster than the dead-band: ``sign(e)*de/dt < -rate_deadband``.
  ``e_max`` is latched to the error at that D->C switch (the turning point of the divergence swing).
* It **stays in C** while ``|e|`` keeps decreasing (``sign(e)*de/dt < 0``) and ``e`` keeps the sign of ``e_max``.
  It **returns to D** as soon as ``|e|`` stops decreasing or the error crosses zero (the paper's sign change:
  crossing the target ends the convergence). The two thresholds (-rate_deadband to enter, 0 to leave) form a
  hysteresis so that rate noise smaller than the dead-band cannot chatter the phase.
* This is the reading of the public ROS 1 implementation (wxmerkt/superimposition_of_passive_taskspace_controllers,
  ``fractal_impedance_controller.hpp``): divergence while the error grows or the speed is below a threshold,
  convergence about the mid-point ``e_max/2``. That code sizes the C stiffness from the stored energy; here the
  C law is the paper's, whose force is continuous at D->C (both equal F_c(e_max)).

Why it converges: a mass released from rest at ``e_max`` under the C law is a harmonic oscillator about
``e_max/2`` with amplitude ``e_max/2``; it reaches ``e = 0`` with zero velocity (the "harmonic trajectory").
The C law's force then points back to ``e_max/2``, ``|e|`` would grow, the axis returns to D where
F_c(0) = 0 holds it: the energy of the swing is dissipated by the phase switch (the FIC has no damping term).
A free unit mass converges to a residual oscillation whose speed is below the dead-band, i.e. an amplitude
below ``rate_deadband / sqrt(K0/m)``.

Stored energy (a potential V with dV/de = FIC(e), so that kinetic + V is constant along any free motion
inside one phase):

* D: ``V_D(e) = integral_0^|e| F_c`` (``ForceProfile.energy``).
* C: ``V_C(e) = K_C/2*(e - e_max/2)^2 + c`` with ``K_C = 2*F_c(e_max)/e_max`` and ``c`` chosen so that
  ``V_C(e_max) = V_D(e_max)``: the D->C switch neither creates nor destroys energy. By symmetry
  ``V_C(0) = V_D(e_max)`` and the C->D switch at ``e ~ 0`` drops it to ``V_D(0) = 0``: that drop is the
  dissipation. ``c = V_D(e_max) - F_c(e_max)*e_max/4`` is negative when the profile is locally convex at
  ``e_max`` (small xi, e_max in the first half of the tanh), so V_C can dip below zero mid-swing there; the
  sum kinetic + V still never grows along a free motion.

Tiny ``e_max``: ``K_C`` uses ``ForceProfile.secant_stiffness``, F_c(e)/e with its finite limit at 0, so there
is no division by ~0 (``e_max`` itself is never exactly zero: entering C needs ``sign(e) != 0``), and as
``e_max -> 0`` the C law tends to the spring ``2*F_c'(0)*(e - e_max/2)``, whose force tends to zero.
The C force is clipped to ``|F_c(e_max)|`` (only reachable if a caller's rate disagrees with its error), so
|FIC| <= F_max always.
"""
from __future__ import annotations

from enum import IntEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.errors import FicInputError, finite_array, finite_scalar
from fic_core.profile import ForceProfile, _profile_force

#: Default dead-band on d|e|/dt [m/s or rad/s] for entering C: well above the noise of a differentiated
#: 1 kHz joint-velocity signal, well below the speeds of a deliberate motion.
DEFAULT_RATE_DEADBAND = 0.005


class Phase(IntEnum):
    """Phase of one FIC axis (values as fic_teleop_msgs/FicState's PHASE_* constants)."""

    DIVERGENCE = 0
    CONVERGENCE = 1


class FractalAttractor:
    """Per-axis FIC attractor, paper Eq. 2, for ``axes`` independent axes sharing one force profile."""

    def __init__(self, profile: ForceProfile, axes: int, rate_deadband: float = DEFAULT_RATE_DEADBAND) -> None:
        if not isinstance(profile, ForceProfile):
            raise FicInputError(f"profile must be a ForceProfile, got {type(profile).__name__}")
        if isinstance(axes, bool) or not isinstance(axes, (int, np.integer)) or axes < 1:
            raise FicInputError(f"axes must be a positive integer, got {axes!r}")
        self._profile = profile
        self._axes = int(axes)
        self._rate_deadband = finite_scalar("rate_deadband", rate_deadband, minimum=0.0)
        self.reset()

    def reset(self) -> None:
        """Back to D on every axis, nothing latched, no force, no stored energy."""
        self._in_convergence = np.zeros(self._axes, dtype=bool)
        self._latched_max_error = np.zeros(self._axes)
        self._convergence_stiffness = np.zeros(self._axes)  # K_C = 2*F_c(e_max)/e_max, per axis
        self._convergence_offset = np.zeros(self._axes)  # c in V_C, per axis
        self._last_error = np.zeros(self._axes)
        self._last_force = np.zeros(self._axes)

    @property
    def profile(self) -> ForceProfile:
        return self._profile

    @property
    def axes(self) -> int:
        return self._axes

    @property
    def rate_deadband(self) -> float:
        return self._rate_deadband

    @property
    def phase(self) -> NDArray[np.int64]:
        """Phase per axis (Phase.DIVERGENCE = 0 or Phase.CONVERGENCE = 1), a copy."""
        return np.where(self._in_convergence, int(Phase.CONVERGENCE), int(Phase.DIVERGENCE)).astype(np.int64)

    @property
    def latched_max_error(self) -> NDArray[np.float64]:
        """e_max latched at each axis's last D->C switch (zero before the first), a copy."""
        return self._latched_max_error.copy()

    @property
    def last_force(self) -> NDArray[np.float64]:
        """The force returned by the last ``force`` call, a copy."""
        return self._last_force.copy()

    @property
    def stored_energy(self) -> NDArray[np.float64]:
        """Energy stored in each axis's spring at the last ``force`` call [J] (see the module docstring)."""
        divergence_energy = self._profile.energy(self._last_error)
        centred = self._last_error - 0.5 * self._latched_max_error
        convergence_energy = 0.5 * self._convergence_stiffness * centred ** 2 + self._convergence_offset
        return np.where(self._in_convergence, convergence_energy, divergence_energy)

    def force(self, error: ArrayLike, error_rate: ArrayLike) -> NDArray[np.float64]:
        """FIC(e) per axis (paper Eq. 2); updates the phase state.

        Args:
            error: e = x_d - x per axis [m or rad], shape (axes,).
            error_rate: de/dt per axis [m/s or rad/s], shape (axes,), from the caller (e.g. desired minus
                measured velocity), so no differencing happens here.
        Returns:
            The force per axis [N or N m], shape (axes,).
        """
        error = finite_array("error", error, (self._axes,))
        error_rate = finite_array("error_rate", error_rate, (self._axes,))
        magnitude_rate = np.sign(error) * error_rate  # d|e|/dt
        same_side = np.sign(error) == np.sign(self._latched_max_error)
        # Stay in C while |e| keeps decreasing on the same side of the target; enter C past the dead-band.
        staying = self._in_convergence & (magnitude_rate < 0.0) & same_side
        entering = ~self._in_convergence & (magnitude_rate < -self._rate_deadband)
        if np.any(entering):
            latched = error[entering]
            stiffness = 2.0 * self._profile.secant_stiffness(latched)  # K_C = 2*F_c(e_max)/e_max
            self._latched_max_error[entering] = latched
            self._convergence_stiffness[entering] = stiffness
            # V_C(e_max) = V_D(e_max): c = V_D(e_max) - K_C*e_max^2/8.
            self._convergence_offset[entering] = self._profile.energy(latched) - stiffness * latched ** 2 / 8.0
        self._in_convergence = staying | entering

        profile = self._profile  # already validated; evaluate Eq. 1 without re-checking its parameters
        divergence_force = _profile_force(error, profile.stiffness, profile.saturation_error,
                                          profile.saturation_start, profile.max_force)  # Eq. 2, D
        convergence_force = self._convergence_stiffness * (error - 0.5 * self._latched_max_error)  # Eq. 2, C
        convergence_limit = self._convergence_stiffness * 0.5 * np.abs(self._latched_max_error)  # |F_c(e_max)|
        convergence_force = np.clip(convergence_force, -convergence_limit, convergence_limit)
        force = np.where(self._in_convergence, convergence_force, divergence_force)
        self._last_error = error
        self._last_force = force
        return force.copy()


class PoseAttractor:
    """The replica's Cartesian FIC: a 3-axis translational and a 3-axis rotational FractalAttractor.

    Translation runs Eq. 2 on the position error per base-frame axis; beyond the paper (SPEC 1.2), rotation runs
    it on the rotation-vector (log map) error per axis. The 6-vectors are ordered x, y, z, rx, ry, rz.
    """

    controller_name = "fic"

    def __init__(self, translation: ForceProfile, rotation: ForceProfile,
                 rate_deadband_translation: float = DEFAULT_RATE_DEADBAND,
                 rate_deadband_rotation: float = DEFAULT_RATE_DEADBAND) -> None:
        rate_deadband_translation = finite_scalar("rate_deadband_translation", rate_deadband_translation, minimum=0.0)
        rate_deadband_rotation = finite_scalar("rate_deadband_rotation", rate_deadband_rotation, minimum=0.0)
        self._translation = FractalAttractor(translation, 3, rate_deadband_translation)
        self._rotation = FractalAttractor(rotation, 3, rate_deadband_rotation)

    @property
    def translation(self) -> FractalAttractor:
        return self._translation

    @property
    def rotation(self) -> FractalAttractor:
        return self._rotation

    def reset(self) -> None:
        self._translation.reset()
        self._rotation.reset()

    def wrench(self, position_error: ArrayLike, rotation_error: ArrayLike, twist_error: ArrayLike) -> NDArray[np.float64]:
        """FIC wrench [N, N m] (Eq. 2 per axis) for the pose error and its rate.

        Args:
            position_error: x_d - x [m], shape (3,).
            rotation_error: rotation vector of R_d * R^T (log map) [rad], shape (3,), base frame.
            twist_error: d/dt of (position_error, rotation_error): desired minus measured twist [m/s, rad/s],
                shape (6,), base frame.
        """
        twist_error = finite_array("twist_error", twist_error, (6,))
        force = self._translation.force(finite_array("position_error", position_error, (3,)), twist_error[:3])
        torque = self._rotation.force(finite_array("rotation_error", rotation_error, (3,)), twist_error[3:])
        return np.concatenate([force, torque])

    @property
    def phase(self) -> NDArray[np.int64]:
        return np.concatenate([self._translation.phase, self._rotation.phase])

    @property
    def latched_max_error(self) -> NDArray[np.float64]:
        return np.concatenate([self._translation.latched_max_error, self._rotation.latched_max_error])

    @property
    def last_force(self) -> NDArray[np.float64]:
        return np.concatenate([self._translation.last_force, self._rotation.last_force])

    @property
    def stored_energy(self) -> NDArray[np.float64]:
        return np.concatenate([self._translation.stored_energy, self._rotation.stored_energy])
