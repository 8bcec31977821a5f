"""The replica's Cartesian FIC: Eq. 2 per axis on translation, and on orientation the FIC on the rotation angle.

Translation runs the paper's Eq. 2 per base-frame axis (fic_core/attractor.py). Orientation (beyond the paper)
runs it on the rotation angle theta = |log3(R_d R^T)| along the rotation axis (fic_core/rotational_attractor.py):
a conservative moment field on SO(3), where the per-axis rule on the rotation vector was not
(docs/CONTROL_LAWS.md, "Rotation"). The 6-vectors are ordered x, y, z, rx, ry, rz.

On a late tick (``late_tick``: the last torque was held longer than the nominal period) each axis also gets the
damper that gives back what its spring loses to that sample-and-hold, B = K (T - T_0)/2 on the error rate
(fic_core/sampled_spring_damping.py); on ticks on time the wrench is Eq. 2's alone. The snapshot reports the FIC's
forces, without that damper.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.attractor import DEFAULT_RATE_DEADBAND, AttractorSnapshot, FractalAttractor
from fic_core.errors import finite_floats, finite_scalar
from fic_core.profile import ForceProfile
from fic_core.rotational_attractor import AngleAxisSnapshot, RotationalAttractor
from fic_core.sampled_spring_damping import hold_damping


class PoseAttractorSnapshot:
    """The two snapshots of a PoseAttractor after one ``wrench`` call; 6-vectors x, y, z, rx, ry, rz on read.

    The rotational slots follow fic_core/rotational_attractor.py: one phase on all three, the moment as the force,
    the angle's scalars (e_max, V) in the first slot.
    """

    __slots__ = ("translation", "rotation")

    def __init__(self, translation: AttractorSnapshot, rotation: AngleAxisSnapshot) -> None:
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
        return np.array(self.translation.storage_values() + self.rotation.storage_values(), dtype=np.float64)

    def port_values(self) -> tuple[tuple[float, ...], tuple[float, ...], list[float]]:
        """(errors, forces, storages) of the 6 slots: what a per-axis passivity observer reads
        (passivity_observer.py): the three translational ports, then the angle's port and two empty slots."""
        errors, forces, storages = self.translation.port_values()
        rotation_errors, moments, rotation_storages = self.rotation.port_values()
        return errors + rotation_errors, forces + moments, storages + rotation_storages


class PoseAttractor:
    """Translational FractalAttractor (3 axes) and RotationalAttractor (module docstring)."""

    controller_name = "fic"

    def __init__(self, translation: ForceProfile, rotation: ForceProfile,
                 rate_deadband_translation: float = DEFAULT_RATE_DEADBAND,
                 rate_deadband_rotation: float = DEFAULT_RATE_DEADBAND) -> None:
        rate_deadband_translation = finite_scalar("rate_deadband_translation", rate_deadband_translation, minimum=0.0)
        rate_deadband_rotation = finite_scalar("rate_deadband_rotation", rate_deadband_rotation, minimum=0.0)
        self._translation = FractalAttractor(translation, 3, rate_deadband_translation)
        self._rotation = RotationalAttractor(rotation, rate_deadband_rotation)
        self._late = 0.0   # [s] T - T_0 of this tick's sample-and-hold (fic_core/sampled_spring_damping.py)

    @property
    def translation(self) -> FractalAttractor:
        return self._translation

    @property
    def rotation(self) -> RotationalAttractor:
        return self._rotation

    def reset(self) -> None:
        self._translation.reset()
        self._rotation.reset()

    def late_tick(self, late: float) -> None:
        """The next wrenches are for a torque held ``late`` = T - T_0 seconds beyond the nominal period
        (sampled_spring_damping.late_hold; 0.0: on time, Eq. 2 alone)."""
        self._late = float(late) if late > 0.0 else 0.0

    def wrench(self, position_error: ArrayLike, rotation_error: ArrayLike,
               twist_error: ArrayLike) -> NDArray[np.float64]:
        """FIC wrench [N, N m]: Eq. 2 per translational axis, the angle-axis FIC on orientation.

        Args:
            position_error: x_d - x [m], shape (3,).
            rotation_error: rotation vector of R_d * R^T (log map) [rad], shape (3,), base frame.
            twist_error: desired minus measured twist [m/s, rad/s], shape (6,), base frame.
        """
        twist_error = finite_floats("twist_error", twist_error, 6)
        return np.array(self.wrench_values(finite_floats("position_error", position_error, 3),
                                           finite_floats("rotation_error", rotation_error, 3), twist_error),
                        dtype=np.float64)

    def wrench_values(self, position_error: list[float], rotation_error: list[float],
                      twist_error: list[float]) -> list[float]:
        """``wrench`` on Python floats its caller has already validated as finite (the replica's tick), as a list
        of 6 floats: the same law without ``wrench``'s input checks and arrays."""
        wrench = self._translation._step(position_error, twist_error) + \
            self._rotation._step(rotation_error, twist_error[3:])
        if self._late > 0.0:
            self._add_hold_damping(wrench, twist_error)
        return wrench

    def _add_hold_damping(self, wrench: list[float], twist_error: list[float]) -> None:
        """B = K (T - T_0)/2 per axis on the error rate, K the axis's stiffness in its phase (K_0 in D, K_C in C);
        the rotation's one angle sets the isotropic rotational damper."""
        translation = self._translation.snapshot()
        for axis in range(3):
            wrench[axis] += hold_damping(translation.phase_stiffness(axis), self._late) * twist_error[axis]
        damping = hold_damping(self._rotation.snapshot().scalar.phase_stiffness(0), self._late)
        for axis in range(3, 6):
            wrench[axis] += damping * twist_error[axis]

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
