"""The master controller (paper Eq. 3, docs/CONTROL_LAWS.md): the handle's own FIC plus the scaled replica force.

    f = FIC(-x_M) + k_F * K_H * F_R ,   K_H in [0, 1],   k_F * s_M * K_H <= 1

``x_M`` is the handle's displacement from its local origin x_Md = 0, so the FIC's error is ``0 - x_M``: the
attractor pulls the handle back to the origin (the operator feels the command's spring). ``F_R`` is the force
the environment applies to the replica's end-effector, so a push into a wall is felt as a push back.
The haptic gain ``K_H`` is changed online (the paper uses the Sigma.7's grasp DoF): values outside [0, 1] are
clamped and the clamp is reported to the caller, who logs it. The force scale ``k_F`` (beyond the paper: 1 is
Eq. 3 as written) scales what the operator feels of F_R, as the motion scale ``s_M`` (the offset mode's
workspace scale) scales what the replica is told of x_M.

The loop gain. Through the handle, x_d', the replica and its contact, and back, the operator feels the stiffness
the replica meets times G = k_F s_M K_H: a handle moved by dx moves x_d' by s_M dx, the replica's contact answers
with K_R s_M dx, and the handle renders k_F K_H of that. A positive scale keeps a passive environment passive, but
the loop carries the delay both ways, and a spring felt one round trip late feeds energy in at a rate that grows
with its stiffness; the project's delay results (docs/RESULTS.md) are measured with the paper's loop, s_M = 1 and
k_F = 1, where Eq. 3's K_H <= 1 bounds G by 1. So G may not exceed 1 (``MAX_LOOP_GAIN``): a smaller motion scale
buys a larger force scale (s_M = 0.25 for fine work allows k_F up to 4 at K_H = 1), never a stiffer loop.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.attractor import FractalAttractor
from fic_core.errors import FicInputError, finite_array, finite_scalar
from fic_core.norm_bound import norm_bounded

#: The bound on the loop gain G = k_F s_M K_H (module docstring; docs/CONTROL_LAWS.md, "Master").
MAX_LOOP_GAIN = 1.0


def loop_gain(force_scale: float, workspace_scale: float, haptic_gain: float) -> float:
    """G = k_F s_M K_H: the share of the stiffness the replica meets that the operator feels through the loop."""
    return force_scale * workspace_scale * haptic_gain


def checked_loop_gain(force_scale: float, workspace_scale: float, haptic_gain: float) -> float:
    """G, or FicInputError in one line if it is above MAX_LOOP_GAIN."""
    gain = loop_gain(force_scale, workspace_scale, haptic_gain)
    if gain > MAX_LOOP_GAIN * (1.0 + 1e-12):
        raise FicInputError(
            f"force_scale x workspace_scale x haptic_gain = {force_scale:g} x {workspace_scale:g} x {haptic_gain:g} "
            f"= {gain:.3g} is above the loop-gain bound {MAX_LOOP_GAIN:g} (docs/CONTROL_LAWS.md, \"Master\"): "
            "refused")
    return gain


def haptic_gain_ceiling(force_scale: float, workspace_scale: float) -> float:
    """The largest K_H the bound allows with these scales (at most 1, Eq. 3's own bound)."""
    scales = force_scale * workspace_scale
    return 1.0 if scales <= MAX_LOOP_GAIN else MAX_LOOP_GAIN / scales


class MasterLaw:
    """Paper Eq. 3 with an online haptic gain and an optional saturation of the device force."""

    def __init__(self, attractor: FractalAttractor, haptic_gain: float, max_device_force: float | None = None,
                 force_scale: float = 1.0) -> None:
        """
        Args:
            attractor: a 3-axis FractalAttractor for the handle (FIC(-x_M)).
            haptic_gain: K_H; clamped to [0, 1] (``haptic_gain_clamped`` tells whether it was).
            max_device_force: if given, the total force's norm is scaled down to it [N] (a Sigma.7 renders about
                20 N continuously); None leaves the force unsaturated.
            force_scale: k_F >= 0, the scale of F_R on the handle (1: Eq. 3 as written). The loop-gain bound is
                the caller's to check (it needs s_M: ``checked_loop_gain``).
        """
        if not isinstance(attractor, FractalAttractor) or attractor.axes != 3:
            raise FicInputError("attractor must be a FractalAttractor with 3 axes")
        self._attractor = attractor
        self._max_device_force = (None if max_device_force is None else
                                  finite_scalar("max_device_force", max_device_force, minimum=0.0,
                                                minimum_inclusive=False))
        self._haptic_gain = 0.0
        self._force_scale = finite_scalar("force_scale", force_scale, minimum=0.0)
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
    def force_scale(self) -> float:
        """k_F >= 0."""
        return self._force_scale

    @force_scale.setter
    def force_scale(self, value: float) -> None:
        self._force_scale = finite_scalar("force_scale", value, minimum=0.0)

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

    def force(self, handle_position: ArrayLike, handle_velocity: ArrayLike, replica_force: ArrayLike,
              guidance_force: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """The device force f [N] of Eq. 3.

        Args:
            handle_position: x_M [m], shape (3,).
            handle_velocity: dx_M/dt [m/s], shape (3,); the FIC's error rate is its negative.
            replica_force: F_R [N], shape (3,), the environment's force on the replica, base frame.
            guidance_force: a guidance fixture's force [N] (fic_core.guidance_fixture), added before the device's
                bound; None: none.
        """
        handle_position = finite_array("handle_position", handle_position, (3,))
        handle_velocity = finite_array("handle_velocity", handle_velocity, (3,))
        replica_force = finite_array("replica_force", replica_force, (3,))
        # Eq. 3: error = x_Md - x_M = -x_M, its rate = -dx_M/dt; F_R scaled by k_F K_H (k_F = 1: as written).
        force = self._attractor.force(-handle_position, -handle_velocity) + \
            (self._force_scale * self._haptic_gain) * replica_force
        if guidance_force is not None:
            force = force + guidance_force
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
