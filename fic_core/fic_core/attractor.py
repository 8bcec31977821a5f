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

Implementation: the per-axis logic runs on plain Python floats (3 axes: numpy's per-call overhead would cost
more than the arithmetic), and each ``force`` call replaces an immutable ``AttractorSnapshot`` of the state, so
the stored energy is computed only when read (``stored_energy``, e.g. when a node publishes FicState), and a
snapshot taken at one tick (``snapshot()``) still reports that tick after later calls.
"""
from __future__ import annotations

from enum import IntEnum
from operator import itemgetter

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.errors import FicInputError, finite_floats, finite_scalar
from fic_core.profile import ForceProfile

_new_snapshot = tuple.__new__  # AttractorSnapshot's __new__ without its call, on the tick

#: Default dead-band on d|e|/dt [m/s or rad/s] for entering C: well above the noise of a differentiated
#: 1 kHz joint-velocity signal, well below the speeds of a deliberate motion.
DEFAULT_RATE_DEADBAND = 0.005


class Phase(IntEnum):
    """Phase of one FIC axis (values as fic_teleop_msgs/FicState's PHASE_* constants)."""

    DIVERGENCE = 0
    CONVERGENCE = 1


class AttractorSnapshot(tuple):
    """The state of a FractalAttractor after one ``force`` call, immutable; derived values computed on read.

    Tuples per axis: whether the axis is in C, e_max, K_C = 2*F_c(e_max)/e_max, the offset c of V_C, and the
    error and force of that call. (A tuple underneath: one C call to create at each tick.)
    """

    __slots__ = ()

    def __new__(cls, profile: ForceProfile, in_convergence: tuple[bool, ...], latched_max_errors: tuple[float, ...],
                convergence_stiffness: tuple[float, ...], convergence_offset: tuple[float, ...],
                errors: tuple[float, ...], forces: tuple[float, ...]) -> AttractorSnapshot:
        return tuple.__new__(cls, (profile, in_convergence, latched_max_errors, convergence_stiffness,
                                   convergence_offset, errors, forces))

    profile = property(itemgetter(0))
    in_convergence = property(itemgetter(1))
    latched_max_errors = property(itemgetter(2))
    convergence_stiffness = property(itemgetter(3))
    convergence_offset = property(itemgetter(4))
    errors = property(itemgetter(5))
    forces = property(itemgetter(6))

    @property
    def phase(self) -> NDArray[np.int64]:
        """Phase per axis (Phase.DIVERGENCE = 0 or Phase.CONVERGENCE = 1)."""
        return np.array(self.in_convergence, dtype=np.int64)

    @property
    def latched_max_error(self) -> NDArray[np.float64]:
        return np.array(self.latched_max_errors, dtype=np.float64)

    @property
    def last_force(self) -> NDArray[np.float64]:
        return np.array(self.forces, dtype=np.float64)

    @property
    def stored_energy(self) -> NDArray[np.float64]:
        """Energy stored in each axis's spring [J]: V_D in D, V_C in C (see the module docstring)."""
        energy = self.profile._scalar_energy
        return np.array([
            0.5 * stiffness * (error - 0.5 * latched) * (error - 0.5 * latched) + offset if converging
            else energy(error)
            for converging, latched, stiffness, offset, error in zip(
                self.in_convergence, self.latched_max_errors, self.convergence_stiffness, self.convergence_offset,
                self.errors)], dtype=np.float64)


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
        zeros = (0.0,) * self._axes
        self._state = AttractorSnapshot(self._profile, (False,) * self._axes, zeros, zeros, zeros, zeros, zeros)

    @property
    def profile(self) -> ForceProfile:
        return self._profile

    @property
    def axes(self) -> int:
        return self._axes

    @property
    def rate_deadband(self) -> float:
        return self._rate_deadband

    def snapshot(self) -> AttractorSnapshot:
        """The state after the last ``force`` call; later calls do not change it."""
        return self._state

    @property
    def phase(self) -> NDArray[np.int64]:
        """Phase per axis (Phase.DIVERGENCE = 0 or Phase.CONVERGENCE = 1), a copy."""
        return self._state.phase

    @property
    def latched_max_error(self) -> NDArray[np.float64]:
        """e_max latched at each axis's last D->C switch (zero before the first), a copy."""
        return self._state.latched_max_error

    @property
    def last_force(self) -> NDArray[np.float64]:
        """The force returned by the last ``force`` call, a copy."""
        return self._state.last_force

    @property
    def stored_energy(self) -> NDArray[np.float64]:
        """Energy stored in each axis's spring at the last ``force`` call [J] (see the module docstring)."""
        return self._state.stored_energy

    def force(self, error: ArrayLike, error_rate: ArrayLike) -> NDArray[np.float64]:
        """FIC(e) per axis (paper Eq. 2); updates the phase state.

        Args:
            error: e = x_d - x per axis [m or rad], shape (axes,).
            error_rate: de/dt per axis [m/s or rad/s], shape (axes,), from the caller (e.g. desired minus
                measured velocity), so no differencing happens here.
        Returns:
            The force per axis [N or N m], shape (axes,).
        """
        errors = finite_floats("error", error, self._axes)
        rates = finite_floats("error_rate", error_rate, self._axes)
        return np.array(self._step(errors, rates), dtype=np.float64)

    def _step(self, errors: list[float], rates: list[float]) -> list[float]:
        """Eq. 2 on validated floats: the phase logic per axis, then the force; returns the forces.

        ``rates`` may be longer than ``errors`` (the extra values are ignored). This is the common tick, where no
        axis enters C: e_max, K_C and c stay as they are (shared with the previous snapshot); a tick where an axis
        enters C is handed to ``_step_entering``, before any state changes.
        """
        old = self._state
        profile = old[0]
        deadband = -self._rate_deadband
        linear_limit = profile._linear_limit
        phases = []
        forces = []
        for error, rate, converging, latched, stiffness in zip(errors, rates, old[1], old[2], old[3]):
            # d|e|/dt = sign(e) * de/dt, with sign(0) = 0 as numpy.sign.
            if converging:
                # Stay in C while |e| keeps decreasing on the same side of the target (sign(e) == sign(e_max)).
                if (rate < 0.0 and latched > 0.0) if error > 0.0 else \
                        (error < 0.0 and -rate < 0.0 and latched < 0.0):
                    force = stiffness * (error - 0.5 * latched)  # Eq. 2, C
                    limit = stiffness * 0.5 * abs(latched)  # |F_c(e_max)|
                    forces.append(limit if force > limit else (-limit if force < -limit else force))
                    phases.append(True)
                    continue
            elif (rate if error > 0.0 else (-rate if error < 0.0 else 0.0)) < deadband:
                return self._step_entering(errors, rates)  # enters C past the dead-band
            phases.append(False)
            # Eq. 2, D (K0 e in the profile's linear region).
            forces.append(profile.stiffness * error if -linear_limit <= error <= linear_limit
                          else profile._scalar_force(error))
        self._state = _new_snapshot(AttractorSnapshot, (profile, tuple(phases), old[2], old[3], old[4],
                                                        tuple(errors), tuple(forces)))
        return forces

    def _step_entering(self, errors: list[float], rates: list[float]) -> list[float]:
        """``_step`` for a tick where an axis may enter C (latching e_max, K_C and c)."""
        old = self._state
        profile = self._profile
        deadband = -self._rate_deadband
        in_convergence = list(old.in_convergence)
        latched_max_errors = list(old.latched_max_errors)
        convergence_stiffness = list(old.convergence_stiffness)
        convergence_offset = list(old.convergence_offset)
        forces = []
        axis = 0
        for error, rate in zip(errors, rates):
            # d|e|/dt = sign(e) * de/dt, with sign(0) = 0 as numpy.sign.
            magnitude_rate = rate if error > 0.0 else (-rate if error < 0.0 else 0.0)
            if in_convergence[axis]:
                # Stay in C while |e| keeps decreasing on the same side of the target (sign(e) == sign(e_max)).
                latched = latched_max_errors[axis]
                converging = magnitude_rate < 0.0 and ((error > 0.0) == (latched > 0.0)) \
                    and ((error < 0.0) == (latched < 0.0))
            else:
                # Enter C past the dead-band, latching e_max.
                converging = magnitude_rate < deadband
                if converging:
                    stiffness = 2.0 * profile._scalar_secant_stiffness(error)  # K_C = 2*F_c(e_max)/e_max
                    latched_max_errors[axis] = error
                    convergence_stiffness[axis] = stiffness
                    # V_C(e_max) = V_D(e_max): c = V_D(e_max) - K_C*e_max^2/8.
                    convergence_offset[axis] = profile._scalar_energy(error) - stiffness * error * error / 8.0
                in_convergence[axis] = converging
            if converging:
                stiffness = convergence_stiffness[axis]
                latched = latched_max_errors[axis]
                force = stiffness * (error - 0.5 * latched)  # Eq. 2, C
                limit = stiffness * 0.5 * abs(latched)  # |F_c(e_max)|
                forces.append(limit if force > limit else (-limit if force < -limit else force))
            else:
                in_convergence[axis] = False
                forces.append(profile._scalar_force(error))  # Eq. 2, D
            axis += 1
        self._state = AttractorSnapshot(profile, tuple(in_convergence), tuple(latched_max_errors),
                                        tuple(convergence_stiffness), tuple(convergence_offset), tuple(errors),
                                        tuple(forces))
        return forces


class PoseAttractorSnapshot:
    """The two snapshots of a PoseAttractor after one ``wrench`` call; 6-vectors x, y, z, rx, ry, rz on read."""

    __slots__ = ("translation", "rotation")

    def __init__(self, translation: AttractorSnapshot, rotation: AttractorSnapshot) -> None:
        self.translation = translation
        self.rotation = rotation

    @property
    def phase(self) -> NDArray[np.int64]:
        return np.array(self.translation.in_convergence + self.rotation.in_convergence, dtype=np.int64)

    @property
    def latched_max_error(self) -> NDArray[np.float64]:
        return np.array(self.translation.latched_max_errors + self.rotation.latched_max_errors, dtype=np.float64)

    @property
    def last_force(self) -> NDArray[np.float64]:
        return np.array(self.translation.forces + self.rotation.forces, dtype=np.float64)

    @property
    def stored_energy(self) -> NDArray[np.float64]:
        return np.concatenate([self.translation.stored_energy, self.rotation.stored_energy])


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
        twist_error = finite_floats("twist_error", twist_error, 6)
        return np.array(self._wrench_values(finite_floats("position_error", position_error, 3),
                                            finite_floats("rotation_error", rotation_error, 3), twist_error),
                        dtype=np.float64)

    def _wrench_values(self, position_error: list[float], rotation_error: list[float],
                       twist_error: list[float]) -> list[float]:
        """``wrench`` on floats its caller has validated (the replica's tick), as a list of 6 floats."""
        return self._translation._step(position_error, twist_error) + \
            self._rotation._step(rotation_error, twist_error[3:])

    def snapshot(self) -> PoseAttractorSnapshot:
        """The state after the last ``wrench`` call (phase, latched_max_error, last_force, stored_energy on read)."""
        return PoseAttractorSnapshot(self._translation._state, self._rotation._state)

    @property
    def phase(self) -> NDArray[np.int64]:
        return self.snapshot().phase

    @property
    def latched_max_error(self) -> NDArray[np.float64]:
        return self.snapshot().latched_max_error

    @property
    def last_force(self) -> NDArray[np.float64]:
        return self.snapshot().last_force

    @property
    def stored_energy(self) -> NDArray[np.float64]:
        return self.snapshot().stored_energy
