"""The master controller (paper Eq. 3, docs/CONTROL_LAWS.md): the handle's own FIC plus the scaled replica force.

    f = FIC(-x_M) + K_H * F_R ,   K_H in [0, 1]

``x_M`` is the handle's displacement from its local origin x_Md = 0, so the FIC's error is ``0 - x_M``: the
attractor pulls the handle back to the origin (the operator feels the command's spring). ``F_R`` is the force
the environment applies to the replica's end-effector, so a push into a wall is felt as a push back.
The haptic gain ``K_H`` is changed online (the paper uses the Sigma.7's grasp DoF): values outside [0, 1] are
clamped and the clamp is reported to the caller, who logs it.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.attractor import FractalAttractor
from fic_core.errors import FicInputError, finite_array, finite_scalar
from fic_core.norm_bound import norm_bounded


class MasterLaw:
    """Paper Eq. 3 with an online haptic gain and an optional saturation of the device force."""

    def __init__(self, attractor: FractalAttractor, haptic_gain: float, max_device_force: float | None = None) -> None:
        """
        Args:
            attractor: a 3-axis FractalAttractor for the handle (FIC(-x_M)).
            haptic_gain: K_H; clamped to [0, 1] (``haptic_gain_clamped`` tells whether it was).
            max_device_force: if given, the total force's norm is scaled down to it [N] (a Sigma.7 renders about
                20 N continuously); None leaves the force unsaturated.
        """
        if not isinstance(attractor, FractalAttractor) or attractor.axes != 3:
            raise FicInputError("attractor must be a FractalAttractor with 3 axes")
        self._attractor = attractor
        self._max_device_force = (None if max_device_force is None else
                                  finite_scalar("max_device_force", max_device_force, minimum=0.0,
                                                minimum_inclusive=False))
        self._haptic_gain = 0.0
        self.haptic_gain_clamped = False
        self.device_force_saturated = False
        self.set_haptic_gain(haptic_gain)

    @property
    def attractor(self) -> FractalAttractor:
        return self._attractor

    @property
    def max_device_force(self) -> float | None:
        return self._max_device_force

    @max_device_force.setter
    def max_device_force(self, value: float | None) -> None:
        self._max_device_force = (None if value is None else
                                  finite_scalar("max_device_force", value, minimum=0.0, minimum_inclusive=False))

    @property
    def haptic_gain(self) -> float:
        """K_H in [0, 1]."""
        return self._haptic_gain

    @haptic_gain.setter
    def haptic_gain(self, value: float) -> None:
        self.set_haptic_gain(value)

    def set_haptic_gain(self, value: float) -> bool:
        """Set K_H, clamped to [0, 1]; returns True (and sets ``haptic_gain_clamped``) if it was clamped.

        NaN or Inf raise FicInputError: an undefined gain must not silently become 0 or 1.
        """
        requested = finite_scalar("haptic_gain", value)
        self._haptic_gain = min(max(requested, 0.0), 1.0)
        self.haptic_gain_clamped = self._haptic_gain != requested
        return self.haptic_gain_clamped

    def force(self, handle_position: ArrayLike, handle_velocity: ArrayLike, replica_force: ArrayLike) -> NDArray[np.float64]:
        """The device force f [N] of Eq. 3.

        Args:
            handle_position: x_M [m], shape (3,).
            handle_velocity: dx_M/dt [m/s], shape (3,); the FIC's error rate is its negative.
            replica_force: F_R [N], shape (3,), the environment's force on the replica, base frame.
        """
        handle_position = finite_array("handle_position", handle_position, (3,))
        handle_velocity = finite_array("handle_velocity", handle_velocity, (3,))
        replica_force = finite_array("replica_force", replica_force, (3,))
        # Eq. 3: error = x_Md - x_M = -x_M, its rate = -dx_M/dt.
        force = self._attractor.force(-handle_position, -handle_velocity) + self._haptic_gain * replica_force
        self.device_force_saturated = False
        if self._max_device_force is not None:
            # Scale the vector (not per axis) so the direction the operator feels is kept.
            bounded = norm_bounded(force, self._max_device_force)
            self.device_force_saturated = bounded is not force
            force = bounded
        return force

    def reset(self) -> None:
        self._attractor.reset()
        self.device_force_saturated = False
