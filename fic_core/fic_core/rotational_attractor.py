"""The FIC on orientation: paper Eqs. 1 and 2 on the rotation angle, along the rotation axis (beyond the paper).

The paper's FIC is written for one translational axis. Running it per axis on the rotation vector
``r = log3(R_d R^T)`` and applying the result as a base-frame moment (what the replica did before) is not a
conservative field once a component leaves the profile's linear region: a closed orientation loop driven from
outside then takes energy out of the controller with no phase switch at all (docs/CONTROL_LAWS.md, "Rotation").

Here the FIC runs on one scalar, the rotation angle ``theta = |r|`` in [0, pi], and the moment is applied along
the unit axis ``u = r/theta``:

    M = FIC(theta) * r/theta            (base frame; FIC is Eq. 2 with Eq. 1's profile, one axis)

with its storage V(theta) (V_D of Eq. 1's integral in D, V_C in C; fic_core/attractor.py). Why this is the
gradient of V on SO(3): with the base-frame angular velocities w (robot) and w_d (target),
d(R_d R^T)/dt = [w_d] R_d R^T - R_d R^T [w], and ``r`` is an eigenvector of the left and right Jacobians of SO(3)
with eigenvalue 1 (J_l(r) r = J_r(r) r = r; and R_d R^T leaves r unchanged), so

    d theta/dt = (r/theta) . (w_d - w)       exactly, for every theta in (0, pi),

and the power the moment delivers to the robot is ``M . w = -FIC(theta) dtheta/dt`` when the target rests: in D,
minus the rate of V. The moment is therefore the exact gradient of V(theta(R)) with respect to the base-frame
rotation, the field is conservative (isotropic), and the scalar attractor's passivity argument on its port
(theta, FIC(theta)) carries over unchanged: the storage never rises at a switch, and every closed orientation loop
from rest to rest takes energy in (docs/CONTROL_LAWS.md, "Rotation"; test/core/test_rotational_attractor.py
checks the identity with finite differences on SO(3) and drives closed loops).

At theta = 0 the axis is undefined and the moment is zero; at theta = pi (the cut locus of log3) the axis flips,
V stays continuous (theta is the geodesic distance), the moment there is F(pi) either way.

What the snapshot reports: the phase on all three rotational slots (one phase), the moment M as the force, and
the scalar quantities of the angle (theta, e_max, V) in the first rotational slot with zeros in the
other two, so that a per-axis passivity observer reading ``port_values`` books the angle's port exactly.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.attractor import DEFAULT_RATE_DEADBAND, AttractorSnapshot, FractalAttractor
from fic_core.errors import FicInputError, finite_floats
from fic_core.profile import ForceProfile

#: At or below this angle [rad] the axis r/theta is not resolved: the moment is zero and the angle reads 0 (the
#: profile's force there is below K0 * 1e-12 rad).
_SMALLEST_ANGLE = 1e-12


class AngleAxisSnapshot:
    """The state of a RotationalAttractor after one call (module docstring: what each slot reports)."""

    __slots__ = ("angle", "moment", "scalar")

    def __init__(self, angle: float, moment: tuple[float, float, float], scalar: AttractorSnapshot) -> None:
        self.angle = angle          #: theta = |r| [rad]
        self.moment = moment        #: M = FIC(theta) r/theta [N m], base frame
        self.scalar = scalar        #: the one-axis attractor's snapshot on theta

    @property
    def in_convergence(self) -> tuple[bool, bool, bool]:
        converging = self.scalar.in_convergence[0]
        return (converging, converging, converging)

    @property
    def latched_max_errors(self) -> tuple[float, float, float]:
        return (self.scalar.latched_max_errors[0], 0.0, 0.0)

    @property
    def forces(self) -> tuple[float, float, float]:
        return self.moment

    @property
    def errors(self) -> tuple[float, float, float]:
        return (self.angle, 0.0, 0.0)

    def storage_values(self) -> list[float]:
        return self.scalar.storage_values() + [0.0, 0.0]

    @property
    def phase(self) -> NDArray[np.int64]:
        return np.array(self.in_convergence, dtype=np.int64)

    @property
    def latched_max_error(self) -> NDArray[np.float64]:
        return np.array(self.latched_max_errors, dtype=np.float64)

    @property
    def last_force(self) -> NDArray[np.float64]:
        return np.array(self.moment, dtype=np.float64)

    @property
    def stored_energy(self) -> NDArray[np.float64]:
        return np.array(self.storage_values(), dtype=np.float64)

    def port_values(self) -> tuple[tuple[float, ...], tuple[float, ...], list[float]]:
        """(errors, forces, storages) of the angle's port (theta, FIC(theta), V) in the first slot, zeros after."""
        return (self.angle, 0.0, 0.0), (self.scalar.forces[0], 0.0, 0.0), self.storage_values()


class RotationalAttractor:
    """FIC on the rotation angle along the rotation axis: M = FIC(|r|) r/|r| (module docstring)."""

    def __init__(self, profile: ForceProfile, rate_deadband: float = DEFAULT_RATE_DEADBAND) -> None:
        if not isinstance(profile, ForceProfile):
            raise FicInputError(f"profile must be a ForceProfile, got {type(profile).__name__}")
        self._angle = FractalAttractor(profile, 1, rate_deadband)
        self.reset()

    def reset(self) -> None:
        """D at theta = 0, nothing latched, no moment, no storage."""
        self._angle.reset()
        self._state = AngleAxisSnapshot(0.0, (0.0, 0.0, 0.0), self._angle._state)

    @property
    def profile(self) -> ForceProfile:
        return self._angle.profile

    @property
    def rate_deadband(self) -> float:
        return self._angle.rate_deadband

    @property
    def axes(self) -> int:
        """The moment's components (the phase logic itself runs on one scalar, the angle)."""
        return 3

    @property
    def angle_attractor(self) -> FractalAttractor:
        """The one-axis Eq. 2 attractor that runs on theta."""
        return self._angle

    def snapshot(self) -> AngleAxisSnapshot:
        return self._state

    @property
    def phase(self) -> NDArray[np.int64]:
        return self._state.phase

    @property
    def latched_max_error(self) -> NDArray[np.float64]:
        return self._state.latched_max_error

    @property
    def last_force(self) -> NDArray[np.float64]:
        return self._state.last_force

    @property
    def stored_energy(self) -> NDArray[np.float64]:
        return self._state.stored_energy

    def moment(self, rotation_error: ArrayLike, rotation_error_rate: ArrayLike) -> NDArray[np.float64]:
        """M = FIC(theta) r/theta [N m], base frame.

        Args:
            rotation_error: r = log3(R_d R^T) [rad], shape (3,), base frame.
            rotation_error_rate: w_d - w, desired minus measured angular velocity [rad/s], shape (3,), base frame
                (or dr/dt: both give the same d theta/dt, r . dr/dt / theta = r . (w_d - w) / theta). It only
                chooses the phase.
        """
        return np.array(self._step(finite_floats("rotation_error", rotation_error, 3),
                                   finite_floats("rotation_error_rate", rotation_error_rate, 3)), dtype=np.float64)

    def _step(self, rotation_error: list[float], rates: list[float]) -> list[float]:
        """``moment`` on validated floats (``rates`` may be longer than 3: the extra values are ignored)."""
        x, y, z = rotation_error
        angle = math.sqrt(x * x + y * y + z * z)
        if angle > _SMALLEST_ANGLE:
            # d theta/dt = (r/theta) . (w_d - w): the axis is invariant under R_d R^T (module docstring).
            angle_rate = (x * rates[0] + y * rates[1] + z * rates[2]) / angle
            magnitude = self._angle._step([angle], [angle_rate])[0]
            scale = magnitude / angle
            moment = (scale * x, scale * y, scale * z)
        else:
            angle = 0.0
            self._angle._step([0.0], [0.0])
            moment = (0.0, 0.0, 0.0)
        self._state = AngleAxisSnapshot(angle, moment, self._angle._state)
        return list(moment)
