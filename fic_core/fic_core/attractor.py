"""The Fractal Impedance Controller's attractor (paper Eq. 2), per axis, built so that it is passive for every input.

Paper Eq. 2::

    D (divergence):  FIC(e) = F_c(e)
    C (convergence): FIC(e) = 2*F_c(e_max)/e_max * (e - e_max/2)

The switching reading (when an axis is in D or C) is the one the project has always used
(docs/CONTROL_LAWS.md, "The attractor (Eq. 2)"):

* An axis **enters C** when ``|e|`` is decreasing faster than the dead-band: ``sign(e)*de/dt < -rate_deadband``.
* It **stays in C** while ``|e|`` keeps decreasing (``sign(e)*de/dt < 0``) and ``e`` keeps the sign of ``e_max``;
  it **returns to D** as soon as ``|e|`` stops decreasing or the error crosses zero (the paper's sign change).
  The two thresholds form a hysteresis, so rate noise smaller than the dead-band cannot chatter the phase.
* This is the reading of the public ROS 1 implementation (wxmerkt/superimposition_of_passive_taskspace_controllers,
  ``fractal_impedance_controller.hpp``): divergence while the error grows, convergence about ``e_max/2``.

What makes it passive (docs/CONTROL_LAWS.md, "Passivity of the attractor", has the whole argument): each phase's
force is the gradient of a storage V that is convex in e (the force is non-decreasing in e), and every switch at
sample k is built so that the new phase's storage at the previous sample e_{k-1} is at most the old one's there.
Then, with the port work W_k = sum_j F_j (e_j - e_{j-1}) (the force returned at a sample times the displacement
that led to it), ``V_k - V_0 <= W_k`` holds for every input sequence, rates that contradict the errors included:
``V_new(e_k) - V_old(e_{k-1}) <= V_new(e_k) - V_new(e_{k-1}) <= F_new(e_k) (e_k - e_{k-1})`` by convexity.

* **D**: ``F = F_c(e)``, ``V = V_D(|e|)`` with ``V_D = integral_0^a F_c`` (``ForceProfile.energy``, closed form).
* **D -> C** at sample k latches ``e_max = e_{k-1}`` (the sample whose storage is known), its storage
  ``V_latch`` and force ``F_latch`` in D, and the C stiffness
  ``K_C = min(2 F_latch/|e_max|, 8 V_latch/e_max^2)``: the paper's force-continuous stiffness, capped by the
  stored-energy sizing of the public ROS 1 code (K = U/x_mid^2 with x_mid = e_max/2) so that V_C >= 0.
  C force: ``K_C (e - e_max/2)`` clipped to ``|F| <= F_max``; ``V_C(e) = V_latch + integral_{e_max}^e F_C``,
  which equals V_latch at e_max and at 0 and is >= 0 everywhere (its minimum, at e_max/2, is
  ``V_latch - K_C e_max^2/8 >= 0`` by the cap).
* **C -> D** at sample k (|e| stops decreasing, or the error crosses zero) only where it does not raise the
  storage: if ``V_D(|e_{k-1}|) <= V_C(e_{k-1})`` the axis returns to D and the difference is dissipated (this is
  where the FIC, which has no damping term, loses energy); otherwise it stays on the C line (deferred: no switch,
  its storage kept) and the test is repeated at the next sample. So in D the force is always F_c(e), and while
  the error grows inside C it is the C line of the last latch, which repeated strokes cannot lower
  (docs/CONTROL_LAWS.md, "The dead zone, bounded"). The rule before opened a dead zone in D instead
  (F_c(|e| - delta) with V_D(|e_{k-1}| - delta) = V_C(e_{k-1})); strokes inside C ratcheted it up and cut the force.
* Entering C needs a previous sample on the same side of the target as e, with a non-zero force there
  (``|e_{k-1}| > 1e-12 x_b``): otherwise there is no swing to converge from, and the axis stays in D.

The paper's harmonic convergence is kept: a mass released from rest at e_max under any C stiffness is a harmonic
oscillator about e_max/2 of amplitude e_max/2, so it reaches e = 0 with zero velocity, and there the C -> D
switch drops the storage V_C(0) = V_latch to V_D(0) = 0. K_C is the paper's 2 F_latch/e_max whenever
V_latch >= F_latch e_max/4, which holds for the shipped profiles over their range (test_passivity).

Implementation: the per-axis logic runs on plain Python floats (3 axes: numpy's per-call overhead would cost
more than the arithmetic), and each ``force`` call replaces an immutable ``AttractorSnapshot`` of the state, so
the storage is computed only when read (``stored_energy``, e.g. by the passivity observer), and a snapshot taken
at one tick (``snapshot()``) still reports that tick after later calls.
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

#: The smallest |e_max| (as a fraction of x_b) from which an axis enters C: below it e_max^2 in K_C's cap would
#: lose its digits, and the force there is negligible anyway.
_SMALLEST_LATCH = 1e-12


class Phase(IntEnum):
    """Phase of one FIC axis (values as fic_teleop_msgs/FicState's PHASE_* constants)."""

    DIVERGENCE = 0
    CONVERGENCE = 1


def convergence_storage(profile: ForceProfile, latched: float, stiffness: float, latched_energy: float,
                        error: float) -> float:
    """V_C(e) = V_latch + integral_{e_max}^e F_C of the clipped C force F_C = clip(K_C (e - e_max/2), +-F_max) [J].

    With u = e - e_max/2 and the clip width c = F_max/K_C, the integral of F_C from the mid-point is
    K_C u^2/2 for |u| <= c and F_max (|u| - c/2) beyond; at e_max, |u| = |e_max|/2 <= c because
    K_C |e_max|/2 <= F_latch <= F_max.
    """
    if stiffness <= 0.0:
        return latched_energy
    offset = error - 0.5 * latched
    magnitude = abs(offset)
    clip = profile.max_force / stiffness
    if magnitude <= clip:
        potential = 0.5 * stiffness * offset * offset
    else:
        potential = profile.max_force * (magnitude - 0.5 * clip)
    return latched_energy + potential - 0.125 * stiffness * latched * latched


class AttractorSnapshot(tuple):
    """The state of a FractalAttractor after one ``force`` call, immutable; derived values computed on read.

    Tuples per axis: whether the axis is in C, e_max, K_C, V_latch (the storage at the D -> C switch), and the
    error and force of that call. (A tuple underneath: one C call to create at each tick.)
    """

    __slots__ = ()

    def __new__(cls, profile: ForceProfile, in_convergence: tuple[bool, ...], latched_max_errors: tuple[float, ...],
                convergence_stiffness: tuple[float, ...], latched_energies: tuple[float, ...],
                errors: tuple[float, ...], forces: tuple[float, ...]) -> AttractorSnapshot:
        return tuple.__new__(cls, (profile, in_convergence, latched_max_errors, convergence_stiffness,
                                   latched_energies, errors, forces))

    profile = property(itemgetter(0))
    in_convergence = property(itemgetter(1))
    latched_max_errors = property(itemgetter(2))
    convergence_stiffness = property(itemgetter(3))
    latched_energies = property(itemgetter(4))
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

    def storage_values(self) -> list[float]:
        """The storage V per axis [J] as floats (V_D in D, V_C in C; module docstring)."""
        profile = self[0]
        return [convergence_storage(profile, latched, stiffness, latched_energy, error) if converging
                else profile.scalar_energy(error)
                for converging, latched, stiffness, latched_energy, error in zip(
                    self[1], self[2], self[3], self[4], self[5])]

    @property
    def stored_energy(self) -> NDArray[np.float64]:
        """The storage V per axis [J] (module docstring): >= 0, zero at rest at e = 0."""
        return np.array(self.storage_values(), dtype=np.float64)

    def port_values(self) -> tuple[tuple[float, ...], tuple[float, ...], list[float]]:
        """(errors, forces, storages) per axis: what a passivity observer reads (passivity_observer.py)."""
        return self[5], self[6], self.storage_values()

    def phase_stiffness(self, axis: int) -> float:
        """The axis's stiffness in its phase: K_C in C, the profile's K_0 (its largest slope) in D."""
        return self[3][axis] if self[1][axis] else self[0].stiffness


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
        """Back to D on every axis at e = 0, nothing latched, no force, no stored energy."""
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
        """The storage V of each axis at the last ``force`` call [J] (see the module docstring)."""
        return self._state.stored_energy

    def force(self, error: ArrayLike, error_rate: ArrayLike) -> NDArray[np.float64]:
        """FIC(e) per axis (paper Eq. 2); updates the phase state.

        Args:
            error: e = x_d - x per axis [m or rad], shape (axes,).
            error_rate: de/dt per axis [m/s or rad/s], shape (axes,), from the caller (e.g. desired minus
                measured velocity), so no differencing happens here. It only chooses the phase: the storage
                argument holds whatever it says.
        Returns:
            The force per axis [N or N m], shape (axes,).
        """
        errors = finite_floats("error", error, self._axes)
        rates = finite_floats("error_rate", error_rate, self._axes)
        return np.array(self._step(errors, rates), dtype=np.float64)

    def _step(self, errors: list[float], rates: list[float]) -> list[float]:
        """Eq. 2 on validated floats: the phase logic per axis, then the force; returns the forces.

        ``rates`` may be longer than ``errors`` (the extra values are ignored). This is the common tick, where no
        axis switches phase: e_max, K_C and V_latch stay as they are (shared with the previous snapshot); any other
        tick is handed to ``_step_switching``, before any state changes.
        """
        old = self._state
        profile = old[0]
        deadband = -self._rate_deadband
        linear_limit = profile.linear_limit
        max_force = profile.max_force
        phases = []
        forces = []
        for error, rate, converging, latched, stiffness in zip(errors, rates, old[1], old[2], old[3]):
            # d|e|/dt = sign(e) * de/dt, with sign(0) = 0 as numpy.sign.
            if converging:
                # Stay in C while |e| keeps decreasing on the same side of the target (sign(e) == sign(e_max)).
                if (rate < 0.0 and latched > 0.0) if error > 0.0 else \
                        (error < 0.0 and -rate < 0.0 and latched < 0.0):
                    force = stiffness * (error - 0.5 * latched)  # Eq. 2, C (K_C capped: module docstring)
                    forces.append(max_force if force > max_force else (-max_force if force < -max_force else force))
                    phases.append(True)
                    continue
                return self._step_switching(errors, rates)  # C -> D, where the storage allows it
            if (rate if error > 0.0 else (-rate if error < 0.0 else 0.0)) < deadband:
                return self._step_switching(errors, rates)  # may enter C past the dead-band
            phases.append(False)
            # Eq. 2, D (K0 e in the profile's linear region).
            forces.append(profile.stiffness * error if -linear_limit <= error <= linear_limit
                          else profile.scalar_force(error))
        self._state = _new_snapshot(AttractorSnapshot, (profile, tuple(phases), old[2], old[3], old[4],
                                                        tuple(errors), tuple(forces)))
        return forces

    def _step_switching(self, errors: list[float], rates: list[float]) -> list[float]:
        """``_step`` for a tick where an axis may switch phase (module docstring)."""
        old = self._state
        profile = self._profile
        deadband = -self._rate_deadband
        max_force = profile.max_force
        smallest_latch = _SMALLEST_LATCH * profile.saturation_error
        in_convergence = list(old[1])
        latched_max_errors = list(old[2])
        convergence_stiffness = list(old[3])
        latched_energies = list(old[4])
        forces = []
        for axis, (error, rate, previous) in enumerate(zip(errors, rates, old[5])):
            # d|e|/dt = sign(e) * de/dt, with sign(0) = 0 as numpy.sign.
            magnitude_rate = rate if error > 0.0 else (-rate if error < 0.0 else 0.0)
            if in_convergence[axis]:
                latched = latched_max_errors[axis]
                stiffness = convergence_stiffness[axis]
                staying = magnitude_rate < 0.0 and ((error > 0.0) == (latched > 0.0)) and \
                    ((error < 0.0) == (latched < 0.0))
                # C -> D only where the D storage at e_{k-1} does not exceed the C storage there (the difference
                # is dissipated); otherwise the axis stays on the C line, whose storage it keeps (deferred).
                if staying or profile.scalar_energy(previous) > convergence_storage(
                        profile, latched, stiffness, latched_energies[axis], previous):
                    force = stiffness * (error - 0.5 * latched)  # Eq. 2, C
                    forces.append(max_force if force > max_force else (-max_force if force < -max_force else force))
                    continue
                in_convergence[axis] = False
            # D -> C past the dead-band, from a previous sample on the same side with a force there (the sides
            # compared by sign, not by the product e_{k-1} e_k, which underflows to 0 at a subnormal e_k).
            elif magnitude_rate < deadband and (error > 0.0 if previous > 0.0 else error < 0.0) \
                    and abs(previous) > smallest_latch:
                latched_force = profile.scalar_force(abs(previous))
                latched_energy = profile.scalar_energy(previous)
                magnitude = abs(previous)
                # K_C = min(2 F_latch/|e_max|, 8 V_latch/e_max^2): Eq. 2's force-continuous stiffness, capped
                # so that V_C >= 0 (the stored-energy sizing of the ROS 1 code).
                stiffness = min(2.0 * latched_force / magnitude, 8.0 * latched_energy / (magnitude * magnitude))
                in_convergence[axis] = True
                latched_max_errors[axis] = previous
                convergence_stiffness[axis] = stiffness
                latched_energies[axis] = latched_energy
                force = stiffness * (error - 0.5 * previous)  # Eq. 2, C
                forces.append(max_force if force > max_force else (-max_force if force < -max_force else force))
                continue
            forces.append(profile.scalar_force(error))  # Eq. 2, D
        self._state = AttractorSnapshot(profile, tuple(in_convergence), tuple(latched_max_errors),
                                        tuple(convergence_stiffness), tuple(latched_energies), tuple(errors),
                                        tuple(forces))
        return forces

