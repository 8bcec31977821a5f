"""The experiments' baseline: a linear Cartesian impedance with the FIC's stiffness K0 (E4, docs/EXPERIMENTS.md).

    wrench = K*e + D*de/dt ,   e = x_d - x per axis (translation, then rotation vector)

It has the same interface as ``pose_attractor.PoseAttractor`` so the replica can run either.

Damping: a linear spring without damping is conservative and would ring forever, so the baseline needs a
damping term; the FIC has none and gets its dissipation from the D/C phase switch (paper Eq. 2). The
defaults of ``make_baseline_like`` use a damping ratio zeta = 0.7 (near-critical, the usual choice of
Cartesian impedance controllers such as franka_ros's example) on the Panda's effective Cartesian mass of
about 4 kg (3-5 kg over the workspace) and an effective rotational inertia of about 0.1 kg m^2:
D = 2*zeta*sqrt(K*m). With K0 = 1000 N/m this gives D ~ 89 N s/m.

Force bound: the FIC never pushes harder than F_max (paper Eq. 1's saturation); a linear spring does, so a
comparison of the two at large errors would compare bounds, not laws. With ``max_force`` (translation [N],
rotation [N m]) the spring-damper's force (and moment) vector is scaled back onto that norm bound -- the
like-for-like baseline (the replica's controller ``linear_bounded``, with the FIC's F_max).
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.attractor import Phase
from fic_core.errors import finite_floats, finite_scalar
from fic_core.pose_attractor import PoseAttractor

#: Damping ratio of the baseline: near-critical, so it is neither sluggish nor ringing.
DEFAULT_DAMPING_RATIO = 0.7
#: The Panda's effective Cartesian mass at the TCP over its workspace is about 3-5 kg.
DEFAULT_EFFECTIVE_MASS = 4.0
#: The Panda's effective rotational inertia at the TCP [kg m^2], order of magnitude.
DEFAULT_EFFECTIVE_INERTIA = 0.1


class LinearImpedanceSnapshot:
    """The state of a LinearImpedance after one ``wrench`` call, immutable; derived values computed on read."""

    __slots__ = ("stiffness", "errors", "forces")

    def __init__(self, stiffness: tuple[float, ...], errors: tuple[float, ...], forces: tuple[float, ...]) -> None:
        self.stiffness = stiffness
        self.errors = errors
        self.forces = forces

    @property
    def phase(self) -> NDArray[np.int64]:
        """Always DIVERGENCE: a linear spring has no phase; reported so the FicState message stays uniform."""
        return np.full(6, int(Phase.DIVERGENCE), dtype=np.int64)

    @property
    def latched_max_error(self) -> NDArray[np.float64]:
        return np.zeros(6)

    @property
    def last_force(self) -> NDArray[np.float64]:
        return np.array(self.forces, dtype=np.float64)

    @property
    def stored_energy(self) -> NDArray[np.float64]:
        """K*e^2/2 per axis [J]."""
        return np.array([0.5 * k * e * e for k, e in zip(self.stiffness, self.errors)], dtype=np.float64)

    def port_values(self) -> tuple[tuple[float, ...], tuple[float, ...], list[float]]:
        """(errors, forces, storages K e^2/2) per axis, for a passivity observer (passivity_observer.py); the
        damping term D de/dt adds work that the spring's storage does not hold (dissipation, when the rate
        agrees with the errors' motion)."""
        return self.errors, self.forces, [0.5 * k * e * e for k, e in zip(self.stiffness, self.errors)]


class LinearImpedance:
    """Linear spring-damper in Cartesian space, per axis (no saturation, no phase)."""

    controller_name = "linear"

    def __init__(self, translation_stiffness: float, rotation_stiffness: float, translation_damping: float,
                 rotation_damping: float, *, max_force: tuple[float, float] | None = None) -> None:
        translation_stiffness = finite_scalar("translation_stiffness", translation_stiffness, minimum=0.0)
        rotation_stiffness = finite_scalar("rotation_stiffness", rotation_stiffness, minimum=0.0)
        translation_damping = finite_scalar("translation_damping", translation_damping, minimum=0.0)
        rotation_damping = finite_scalar("rotation_damping", rotation_damping, minimum=0.0)
        if max_force is not None:
            max_force = (finite_scalar("max_force[0]", max_force[0], minimum=0.0, minimum_inclusive=False),
                         finite_scalar("max_force[1]", max_force[1], minimum=0.0, minimum_inclusive=False))
        self.max_force = max_force
        if max_force is not None:
            self.controller_name = "linear_bounded"
        # Plain floats per axis: the 6-vector arithmetic of one tick is cheaper without numpy's call overhead.
        self._stiffness_values = (translation_stiffness,) * 3 + (rotation_stiffness,) * 3
        self._damping_values = (translation_damping,) * 3 + (rotation_damping,) * 3
        self.reset()

    @property
    def stiffness(self) -> NDArray[np.float64]:
        return np.array(self._stiffness_values)

    @property
    def damping(self) -> NDArray[np.float64]:
        return np.array(self._damping_values)

    def reset(self) -> None:
        self._state = LinearImpedanceSnapshot(self._stiffness_values, (0.0,) * 6, (0.0,) * 6)

    def wrench(self, position_error: ArrayLike, rotation_error: ArrayLike,
               twist_error: ArrayLike) -> NDArray[np.float64]:
        """K*e + D*de/dt [N, N m]; arguments as ``PoseAttractor.wrench``."""
        position_error = finite_floats("position_error", position_error, 3)
        rotation_error = finite_floats("rotation_error", rotation_error, 3)
        twist_error = finite_floats("twist_error", twist_error, 6)
        return np.array(self.wrench_values(position_error, rotation_error, twist_error), dtype=np.float64)

    def wrench_values(self, position_error: list[float], rotation_error: list[float],
                      twist_error: list[float]) -> list[float]:
        """``wrench`` on Python floats its caller has already validated as finite (the replica's tick), as a list
        of 6 floats: the same law without ``wrench``'s input checks and arrays."""
        error = position_error + rotation_error
        forces = [k * e + d * r for k, e, d, r in zip(self._stiffness_values, error, self._damping_values, twist_error)]
        if self.max_force is not None:
            for start, bound in zip((0, 3), self.max_force):
                norm = math.sqrt(sum(f * f for f in forces[start:start + 3]))
                if norm > bound:
                    forces[start:start + 3] = [f * bound / norm for f in forces[start:start + 3]]
        self._state = LinearImpedanceSnapshot(self._stiffness_values, tuple(error), tuple(forces))
        return forces

    def snapshot(self) -> LinearImpedanceSnapshot:
        """The state after the last ``wrench`` call; later calls do not change it."""
        return self._state

    @property
    def phase(self) -> NDArray[np.int64]:
        """Always DIVERGENCE: a linear spring has no phase; reported so the FicState message stays uniform."""
        return self._state.phase

    @property
    def latched_max_error(self) -> NDArray[np.float64]:
        return self._state.latched_max_error

    @property
    def last_force(self) -> NDArray[np.float64]:
        return self._state.last_force

    @property
    def stored_energy(self) -> NDArray[np.float64]:
        """K*e^2/2 per axis [J]."""
        return self._state.stored_energy


def make_baseline_like(pose_attractor: PoseAttractor, damping_ratio: float = DEFAULT_DAMPING_RATIO,
                       effective_mass: float = DEFAULT_EFFECTIVE_MASS,
                       effective_inertia: float = DEFAULT_EFFECTIVE_INERTIA) -> LinearImpedance:
    """The linear baseline with the same K0 as ``pose_attractor`` and D = 2*zeta*sqrt(K0*m)."""
    damping_ratio = finite_scalar("damping_ratio", damping_ratio, minimum=0.0)
    effective_mass = finite_scalar("effective_mass", effective_mass, minimum=0.0, minimum_inclusive=False)
    effective_inertia = finite_scalar("effective_inertia", effective_inertia, minimum=0.0, minimum_inclusive=False)
    translation_stiffness = pose_attractor.translation.profile.stiffness
    rotation_stiffness = pose_attractor.rotation.profile.stiffness
    return LinearImpedance(
        translation_stiffness=translation_stiffness,
        rotation_stiffness=rotation_stiffness,
        translation_damping=2.0 * damping_ratio * math.sqrt(translation_stiffness * effective_mass),
        rotation_damping=2.0 * damping_ratio * math.sqrt(rotation_stiffness * effective_inertia),
    )
