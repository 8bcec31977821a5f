"""A sigma.7-class haptic device: the master's handle as a 3-DoF translational mass.

The handle is a point mass ``m`` with viscous damping ``b`` inside a box workspace with soft walls:

    m * a = sat(f_command) + f_hand - b * v + f_wall(x, v)

- ``sat`` limits the commanded force to ``max_force`` (20 N, the sigma.7's continuous force) by scaling its
  norm, so a saturated command keeps its direction as the device's amplifier does;
- ``f_hand`` is what the operator's hand applies (virtual_operator.py) and is not saturated: a hand can push
  harder than the motors;
- ``f_wall`` is a stiff spring-damper acting only on an axis that is beyond the workspace, and it only ever
  pushes back in (a wall that could pull the handle outward would be sticky), standing in for the mechanical
  end stops of the real device.

Workspace: the Force Dimension sigma.7 is specified as about 190 mm x 130 mm of translation (a cylinder of
diameter 190 mm and height 130 mm). Here it is a box around the local origin x_Md = 0, 0.19 m along x and
0.13 m along y and z (half-extents 0.095, 0.065, 0.065 m): a box is simpler to reason about in scripts, and the
narrower y keeps the model on the safe side of the real cylinder. The handle position x_M is the displacement
from that origin (paper Eq. 3).

Integration: semi-implicit (symplectic) Euler at a fixed internal substep (1 ms): the velocity is updated
first and the position from the new velocity, which keeps an undamped spring's energy bounded instead of
growing as explicit Euler does. With the default wall (5000 N/m on 0.5 kg, w*h = 0.1) and hand springs the
substep is well inside the stability limit (w*h < 2).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, NamedTuple, Union

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.errors import FicInputError, finite_array, finite_scalar
from fic_core.norm_bound import norm_bounded

Vector3 = NDArray[np.float64]
# The hand force may be a constant for the whole step, or a function of the handle state evaluated at every
# substep (the operator's spring-damper), which keeps the hand-handle coupling as stiff as the substep allows.
HandForce = Union[ArrayLike, Callable[[Vector3, Vector3], ArrayLike]]


@dataclass(frozen=True)
class HapticDeviceParameters:
    """Physical parameters of the device model. Defaults: a sigma.7-class device."""

    mass: float = 0.5                    # effective moving mass at the handle [kg]
    damping: float = 2.0                 # viscous damping of the mechanism [N s/m]
    half_extents: tuple[float, float, float] = (0.095, 0.065, 0.065)   # workspace box half-sizes [m]
    wall_stiffness: float = 5000.0       # soft-wall spring beyond the workspace [N/m]
    wall_damping: float = 50.0           # soft-wall damper beyond the workspace [N s/m]
    max_force: float = 20.0              # saturation of the commanded force's norm [N]
    substep: float = 0.001               # internal integration step [s] (1 kHz)

    def __post_init__(self) -> None:
        finite_scalar("mass", self.mass, minimum=0.0, minimum_inclusive=False)
        finite_scalar("damping", self.damping, minimum=0.0)
        extents = finite_array("half_extents", self.half_extents, shape=(3,))
        if np.any(extents <= 0.0):
            raise FicInputError(f"half_extents must be positive, got {self.half_extents}")
        object.__setattr__(self, "half_extents", tuple(float(e) for e in extents))
        finite_scalar("wall_stiffness", self.wall_stiffness, minimum=0.0)
        finite_scalar("wall_damping", self.wall_damping, minimum=0.0)
        finite_scalar("max_force", self.max_force, minimum=0.0)
        finite_scalar("substep", self.substep, minimum=0.0, minimum_inclusive=False, maximum=0.01)
        # Semi-implicit Euler on the wall spring is stable for w*h < 2; keep a wide margin.
        if math.sqrt(self.wall_stiffness / self.mass) * self.substep > 0.5:
            raise FicInputError("wall_stiffness too high for the substep: sqrt(k/m)*substep must be <= 0.5")


class HapticDeviceState(NamedTuple):
    position: Vector3     # x_M: handle displacement from the local origin [m]
    velocity: Vector3     # handle velocity [m/s]


@dataclass
class HapticDevice:
    """The handle's dynamics. ``step`` advances it; ``state`` is the latest position and velocity."""

    parameters: HapticDeviceParameters = field(default_factory=HapticDeviceParameters)
    position: Vector3 = field(default_factory=lambda: np.zeros(3))
    velocity: Vector3 = field(default_factory=lambda: np.zeros(3))
    _time_debt: float = 0.0   # simulated time asked for but not yet integrated (less than one substep)

    def __post_init__(self) -> None:
        self.position = finite_array("position", self.position, shape=(3,)).copy()
        self.velocity = finite_array("velocity", self.velocity, shape=(3,)).copy()
        self._half_extents = np.asarray(self.parameters.half_extents)

    @property
    def state(self) -> HapticDeviceState:
        return HapticDeviceState(self.position.copy(), self.velocity.copy())

    def saturate(self, command_force: ArrayLike) -> Vector3:
        """The force the motors actually produce for a command: its norm limited to ``max_force``."""
        force = finite_array("command_force", command_force, shape=(3,))
        return norm_bounded(force, self.parameters.max_force)

    def wall_force(self, position: Vector3, velocity: Vector3) -> Vector3:
        """Soft-wall force: spring-damper on each axis beyond the workspace, only ever pushing back inside."""
        excess = np.abs(position) - self._half_extents
        outside = excess > 0.0
        if not np.any(outside):
            return np.zeros(3)
        inward = -np.sign(position)
        # Spring on the penetration depth, damper on the velocity along the outward normal.
        magnitude = (self.parameters.wall_stiffness * excess
                     - self.parameters.wall_damping * velocity * inward)
        return np.where(outside, inward * np.maximum(magnitude, 0.0), 0.0)

    def step(self, command_force: ArrayLike, hand_force: HandForce, dt: float) -> HapticDeviceState:
        """Advance by ``dt`` seconds in fixed substeps under a commanded force and the operator's hand force.

        ``hand_force`` is a 3-vector held for the step, or a callable ``(position, velocity) -> force``
        evaluated at every substep. A ``dt`` that is not a multiple of the substep carries the remainder over
        to the next call, so the device keeps exact time over many calls at any caller rate.
        """
        dt = finite_scalar("dt", dt, minimum=0.0)
        motor_force = self.saturate(command_force)
        hand = hand_force if callable(hand_force) else finite_array("hand_force", hand_force, shape=(3,))
        parameters = self.parameters
        h = parameters.substep
        self._time_debt += dt
        steps = int(math.floor(self._time_debt / h + 1e-9))
        self._time_debt = max(0.0, self._time_debt - steps * h)
        # The substeps on Python floats (numpy's per-call cost dominates on 3-vectors at 1 kHz), each element with the
        # operations, in the order, of m a = sat(f) + f_hand - b v + f_wall: the same numbers as the array form.
        motor_x, motor_y, motor_z = motor_force.tolist()
        damping, gain = parameters.damping, h / parameters.mass
        half_x, half_y, half_z = parameters.half_extents
        held = None if callable(hand) else hand.tolist()
        for _ in range(steps):
            position, velocity = self.position, self.velocity
            hand_x, hand_y, hand_z = held if held is not None else \
                finite_array("hand_force", hand(position, velocity), shape=(3,)).tolist()
            x, y, z = position.tolist()
            vx, vy, vz = velocity.tolist()
            if abs(x) - half_x > 0.0 or abs(y) - half_y > 0.0 or abs(z) - half_z > 0.0:
                wall_x, wall_y, wall_z = self.wall_force(position, velocity).tolist()
            else:
                wall_x = wall_y = wall_z = 0.0   # wall_force's zeros, added as it adds them
            vx = vx + gain * (motor_x + hand_x - damping * vx + wall_x)
            vy = vy + gain * (motor_y + hand_y - damping * vy + wall_y)
            vz = vz + gain * (motor_z + hand_z - damping * vz + wall_z)
            self.velocity = np.array((vx, vy, vz))
            self.position = np.array((x + h * vx, y + h * vy, z + h * vz))
        return self.state

    def inside_workspace(self, margin: float = 0.0) -> bool:
        """True if the handle is within the workspace box enlarged by ``margin`` on every side."""
        return bool(np.all(np.abs(self.position) <= self._half_extents + margin))
