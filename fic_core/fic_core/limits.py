"""The Panda's physical limits and the limit-violation check (docs/CONTROL_LAWS.md, "The limits").

Datasheet values of the Franka Emika Panda; the joint position limits come from the URDF through
``RobotModel``, so the controller and the simulator agree on them.
"""
from __future__ import annotations

import enum
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_array, finite_scalar

if TYPE_CHECKING:
    from .robot_model import RobotModel

PANDA_TORQUE_LIMIT: tuple[float, ...] = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
PANDA_TORQUE_RATE_LIMIT = 1000.0
PANDA_JOINT_VELOCITY_LIMIT: tuple[float, ...] = (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61)
PANDA_TCP_SPEED_LIMIT = 1.7

#: Numerical slack of the violation check: a command exactly on a limit is inside it.
VIOLATION_TOLERANCE = 1e-9


class LimitFlag(enum.IntFlag):
    """Bitmask of Panda limits; same values as the fic_teleop_msgs/LimitStatus constants."""

    NONE = 0
    TORQUE = 1
    TORQUE_RATE = 2
    JOINT_VELOCITY = 4
    JOINT_POSITION = 8
    TCP_SPEED = 16


#: LimitFlag of every combination of the flags, by its int value: LimitFlag(int) costs a microsecond a call, a
#: look-up here a few tens of nanoseconds (the replica's tick and the postural optimisation work on ints).
LIMIT_FLAGS: dict[int, LimitFlag] = {value: LimitFlag(value) for value in range(32)}


def _vector(name: str, value: ArrayLike) -> tuple[float, ...]:
    return tuple(float(x) for x in finite_array(name, value, (7,)))


@dataclass(frozen=True)
class PandaLimits:
    """Limits the replica must never command outside of (docs/CONTROL_LAWS.md).

    Build it with ``PandaLimits.from_robot(robot)`` to take the joint position limits from the URDF.
    """

    joint_position_lower: tuple[float, ...]
    joint_position_upper: tuple[float, ...]
    torque: tuple[float, ...] = PANDA_TORQUE_LIMIT                 # [N m]
    torque_rate: float = PANDA_TORQUE_RATE_LIMIT                   # [N m / s], every joint
    joint_velocity: tuple[float, ...] = PANDA_JOINT_VELOCITY_LIMIT  # [rad / s]
    tcp_speed: float = PANDA_TCP_SPEED_LIMIT                       # [m / s]

    def __post_init__(self) -> None:
        for name in ("joint_position_lower", "joint_position_upper", "torque", "joint_velocity"):
            object.__setattr__(self, name, _vector(name, getattr(self, name)))
        for name in ("torque", "joint_velocity"):
            if min(getattr(self, name)) <= 0.0:
                raise FicInputError(f"{name} limits must be > 0, got {getattr(self, name)}")
        object.__setattr__(self, "torque_rate", finite_scalar("torque_rate", self.torque_rate, minimum=0.0,
                                                              minimum_inclusive=False))
        object.__setattr__(self, "tcp_speed", finite_scalar("tcp_speed", self.tcp_speed, minimum=0.0,
                                                            minimum_inclusive=False))
        if any(lo >= hi for lo, hi in zip(self.joint_position_lower, self.joint_position_upper)):
            raise FicInputError("joint_position_lower must be below joint_position_upper for every joint, got "
                                f"{self.joint_position_lower} and {self.joint_position_upper}")

    @classmethod
    def from_robot(cls, robot: RobotModel, **overrides: object) -> PandaLimits:
        """Datasheet limits with the joint position limits of ``robot``'s URDF."""
        return cls(joint_position_lower=tuple(robot.lower_position_limit),
                   joint_position_upper=tuple(robot.upper_position_limit), **overrides)  # type: ignore[arg-type]

    # Read-only numpy views for the per-tick arithmetic.
    @cached_property
    def torque_array(self) -> NDArray[np.float64]:
        return _frozen(self.torque)

    @cached_property
    def joint_velocity_array(self) -> NDArray[np.float64]:
        return _frozen(self.joint_velocity)

    @cached_property
    def lower_array(self) -> NDArray[np.float64]:
        return _frozen(self.joint_position_lower)

    @cached_property
    def upper_array(self) -> NDArray[np.float64]:
        return _frozen(self.joint_position_upper)


def _frozen(values: tuple[float, ...]) -> NDArray[np.float64]:
    array = np.array(values, dtype=float)
    array.flags.writeable = False
    return array


def limit_violations(previous_torque: ArrayLike | None, torque: ArrayLike, q: ArrayLike, qd: ArrayLike,
                     tcp_speed: float, dt: float, limits: PandaLimits) -> LimitFlag:
    """Limits that a command or a measured state breaks (docs/CONTROL_LAWS.md, "The limits").

    ``torque`` is the command, ``previous_torque`` the command before it (``None`` for the first command: no
    torque rate is defined), ``dt`` the time between the two commands; ``q``, ``qd`` and ``tcp_speed`` are the
    measured state. A value exactly on a limit is inside it.
    """
    torque = finite_array("torque", torque, (7,))
    q = finite_array("q", q, (7,))
    qd = finite_array("qd", qd, (7,))
    tcp_speed = finite_scalar("tcp_speed", tcp_speed, minimum=0.0)
    if previous_torque is not None:
        previous_torque = finite_array("previous_torque", previous_torque, (7,))
        dt = finite_scalar("dt", dt, minimum=0.0, minimum_inclusive=False)
    return violation_flags(previous_torque, torque, q, qd, tcp_speed, dt, limits)


def violation_flags(previous_torque: NDArray[np.float64] | None, torque: NDArray[np.float64],
                    q: NDArray[np.float64], qd: NDArray[np.float64], tcp_speed: float, dt: float,
                    limits: PandaLimits) -> LimitFlag:
    """``limit_violations`` without the input checks, for callers that validated already (the replica tick)."""
    tol = VIOLATION_TOLERANCE
    flags = 0  # plain int arithmetic: IntFlag operators cost microseconds each
    if (np.abs(torque) - limits.torque_array).max() > tol:
        flags |= LimitFlag.TORQUE.value
    if previous_torque is not None and np.abs(torque - previous_torque).max() > limits.torque_rate * dt + tol:
        flags |= LimitFlag.TORQUE_RATE.value
    if (np.abs(qd) - limits.joint_velocity_array).max() > tol:
        flags |= LimitFlag.JOINT_VELOCITY.value
    if min((q - limits.lower_array).min(), (limits.upper_array - q).min()) < -tol:
        flags |= LimitFlag.JOINT_POSITION.value
    if tcp_speed > limits.tcp_speed + tol:
        flags |= LimitFlag.TCP_SPEED.value
    return LimitFlag(flags)
