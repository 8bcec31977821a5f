"""The two teleoperation modes (paper Sec. II-C, Eq. 3): the teleoperated offset x_d' from the handle x_M.

    offset:   x_d' = s_M * x_M                                (better dexterity, master's workspace only)
    velocity: x_d'(t) = x_d'(t - dt) + k_v * x_M * dt         (re-centres the workspace)

Bumpless switching (docs/CONTROL_LAWS.md: switching must not make x_d' jump). The offset mode keeps an anchor
``(x_M_anchor, x_d'_anchor)`` and computes ``x_d' = x_d'_anchor + s_M * (x_M - x_M_anchor)``. The anchor is
(0, 0) after ``reset()`` (so this is exactly ``x_d' = s_M * x_M``), and is re-taken as the current
``(x_M, x_d')`` whenever the offset mode is entered or ``workspace_scale`` changes: x_d' continues from its
value at the switch and then follows the hand's displacement since the switch. Entering the velocity mode
needs no anchor: the integral starts from the current x_d', and its first increment is k_v*x_M*dt (no jump).
A consequence worth knowing: after a velocity->offset switch made with the handle away from its origin,
releasing the handle (the master FIC returns it to x_M = 0) moves x_d' by -s_M*x_M_anchor.

Holding (the clutch, homing; docs/TOOLS.md, "The operator's tools"): while held, x_d' stands still whatever the
handle does. The first update after the hold ends re-anchors at the handle's position of that update, so x_d'
continues from its held value and the handle's new position is the offset mode's origin (indexing); the velocity
mode simply resumes integrating from the held x_d'.

Velocity dead-band: a resting hand never holds the handle exactly at its origin, and in velocity mode any
residual displacement integrates into a drift of the replica. Inside a ball of radius ``velocity_deadband``
around the origin the velocity command is zero; outside it the command is k_v*(|x_M| - deadband) along x_M,
which is continuous at the ball's edge.
"""
from __future__ import annotations

from enum import IntEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.errors import FicInputError, finite_array, finite_scalar

#: Default velocity-mode dead-band [m]: larger than the few millimetres a relaxed hand rests away from the
#: origin under the master's FIC, small against the Sigma.7's ~0.19 m x 0.13 m workspace.
DEFAULT_VELOCITY_DEADBAND = 0.005


class TeleoperationMode(IntEnum):
    """Teleoperation mode (values as fic_teleop_msgs/TeleoperationCommand's MODE_* constants)."""

    OFFSET = 0
    VELOCITY = 1


class TeleoperationCommandIntegrator:
    """Produces the teleoperated offset x_d' from the handle position x_M in either mode, switching bumplessly."""

    def __init__(self, workspace_scale: float = 1.0, velocity_gain: float = 1.0,
                 mode: TeleoperationMode | int = TeleoperationMode.OFFSET,
                 velocity_deadband: float = DEFAULT_VELOCITY_DEADBAND) -> None:
        """
        Args:
            workspace_scale: s_M > 0, the master-to-replica position scale of the offset mode.
            velocity_gain: k_v >= 0 [1/s], the velocity mode's gain.
            mode: the starting mode.
            velocity_deadband: radius [m] of the ball around the origin where the velocity command is zero.
        """
        self._workspace_scale = finite_scalar("workspace_scale", workspace_scale, minimum=0.0,
                                              minimum_inclusive=False)
        self._velocity_gain = finite_scalar("velocity_gain", velocity_gain, minimum=0.0)
        self._velocity_deadband = finite_scalar("velocity_deadband", velocity_deadband, minimum=0.0)
        self._mode = _as_mode(mode)
        self._held = False
        self.reset()

    def reset(self) -> None:
        """x_d' = 0 and the offset anchor at the origin, so the offset mode reads x_d' = s_M * x_M."""
        self._desired_offset = np.zeros(3)
        self._handle_position = np.zeros(3)
        self._anchor_handle = np.zeros(3)
        self._anchor_offset = np.zeros(3)
        self._reanchor = False

    @property
    def held(self) -> bool:
        """True while x_d' holds still whatever the handle does (the clutch held, the handle being homed)."""
        return self._held

    def hold(self, held: bool) -> None:
        """Hold x_d' still, or engage again: the first update after a hold re-anchors (module docstring)."""
        if self._held and not held:
            self._reanchor = True
        self._held = bool(held)

    @property
    def mode(self) -> TeleoperationMode:
        return self._mode

    @property
    def desired_offset(self) -> NDArray[np.float64]:
        """x_d' [m] after the last update, a copy."""
        return self._desired_offset.copy()

    @property
    def workspace_scale(self) -> float:
        return self._workspace_scale

    @workspace_scale.setter
    def workspace_scale(self, value: float) -> None:
        self._workspace_scale = finite_scalar("workspace_scale", value, minimum=0.0, minimum_inclusive=False)
        self._anchor()  # a new scale must not make x_d' jump either

    @property
    def velocity_gain(self) -> float:
        return self._velocity_gain

    @velocity_gain.setter
    def velocity_gain(self, value: float) -> None:
        self._velocity_gain = finite_scalar("velocity_gain", value, minimum=0.0)

    @property
    def velocity_deadband(self) -> float:
        return self._velocity_deadband

    @velocity_deadband.setter
    def velocity_deadband(self, value: float) -> None:
        self._velocity_deadband = finite_scalar("velocity_deadband", value, minimum=0.0)

    def set_mode(self, mode: TeleoperationMode | int) -> None:
        """Switch mode without a jump of x_d' (see the module docstring)."""
        new_mode = _as_mode(mode)
        if new_mode == TeleoperationMode.OFFSET and self._mode != TeleoperationMode.OFFSET:
            self._anchor()
        self._mode = new_mode

    def toggle_mode(self) -> TeleoperationMode:
        """Switch OFFSET <-> VELOCITY (the keyboard/joystick button); returns the new mode."""
        offset = self._mode == TeleoperationMode.OFFSET
        self.set_mode(TeleoperationMode.VELOCITY if offset else TeleoperationMode.OFFSET)
        return self._mode

    def update(self, handle_position: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Advance by dt [s] with the handle at x_M [m]; returns x_d' [m]."""
        handle_position = finite_array("handle_position", handle_position, (3,))
        dt = finite_scalar("dt", dt, minimum=0.0)
        self._handle_position = handle_position
        if self._held:
            return self._desired_offset.copy()
        if self._reanchor:   # engaged again: x_d' continues from its held value, this handle is the new origin
            self._reanchor = False
            self._anchor()
        if self._mode == TeleoperationMode.OFFSET:
            self._desired_offset = self._anchor_offset + self._workspace_scale * (handle_position - self._anchor_handle)
        else:
            self._desired_offset = self._desired_offset + self._velocity_gain * self._deadbanded(handle_position) * dt
        return self._desired_offset.copy()

    def goal_at(self, handle_position: NDArray[np.float64]) -> NDArray[np.float64]:
        """x_d' as the next update would make it with the handle at ``handle_position``, the state left as it is
        (the master's control tick runs between network ticks): the offset mode's map, else the last x_d' (held,
        or the velocity mode's integral, which advances at the network ticks only). Not a copy: read it only."""
        if self._held or self._reanchor or self._mode != TeleoperationMode.OFFSET:
            return self._desired_offset
        return self._anchor_offset + self._workspace_scale * (handle_position - self._anchor_handle)

    def _deadbanded(self, handle_position: NDArray[np.float64]) -> NDArray[np.float64]:
        distance = float(np.linalg.norm(handle_position))
        if distance <= self._velocity_deadband:
            return np.zeros(3)
        return handle_position * (1.0 - self._velocity_deadband / distance)

    def _anchor(self) -> None:
        self._anchor_handle = self._handle_position.copy()
        self._anchor_offset = self._desired_offset.copy()


def _as_mode(mode: TeleoperationMode | int) -> TeleoperationMode:
    try:
        return TeleoperationMode(int(mode))
    except (TypeError, ValueError) as exc:
        raise FicInputError(f"mode must be TeleoperationMode.OFFSET (0) or VELOCITY (1), got {mode!r}") from exc
