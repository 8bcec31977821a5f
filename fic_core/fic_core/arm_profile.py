"""Which Franka arm the replica drives: its joint names and its datasheet limits (Panda or FR3).

Both arms share one kinematic chain: franka_description's ``robots/fr3/kinematics.yaml`` and
``robots/fer/kinematics.yaml`` (the Panda, "FER") hold the same joint origins, so the Panda URDF that Pinocchio and
MuJoCo load here (example-robot-data) gives an FR3's TCP pose and Jacobian too. What differs is recorded in
docs/HARDWARE.md ("Model"): the link inertias (franka_description's ``inertials.yaml`` differ, e.g. link 1
2.93 kg on the FR3 against 2.79 kg on the Panda), the joint limits and the velocity and TCP-speed limits below.
An FR3 driver compensates gravity with its own model, so the inertia differences enter the replica's law only
through C(q, qd) qd, M(q) and the postural optimisation's predictions.

Joint position limits used by the replica are the intersection of the arm's datasheet range and the loaded
model's URDF range: a joint is never commanded outside either (on an FR3, joint 6's datasheet range
[0.5445, 4.5169] rad is cut at the Panda URDF's 3.7525 rad, a posture the task never needs).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .errors import FicInputError
from .limits import PandaLimits

ARM_TYPES = ("panda", "fr3")


@dataclass(frozen=True)
class ArmProfile:
    """One arm's joint-name prefix and datasheet limits (every tuple in joint order 1..7)."""

    name: str
    joint_prefix: str
    joint_position_lower: tuple[float, ...]   # [rad]
    joint_position_upper: tuple[float, ...]   # [rad]
    joint_velocity: tuple[float, ...]         # [rad/s]
    torque: tuple[float, ...]                 # [N m]
    torque_rate: float                        # [N m/s], every joint
    tcp_speed: float                          # [m/s]
    source: str                               # where the numbers come from (docs/HARDWARE.md cites it)

    def joint_names(self, prefix: str | None = None) -> tuple[str, ...]:
        """``<prefix>_joint1..7`` (ros2_control's and franka_description's naming)."""
        stem = self.joint_prefix if prefix is None else prefix
        return tuple(f"{stem}_joint{i}" for i in range(1, 8))

    def limits_for(self, lower_model: ArrayLike, upper_model: ArrayLike) -> PandaLimits:
        """The replica's limits: these datasheet values, joint positions cut to the model's URDF range too."""
        lower = np.maximum(np.asarray(self.joint_position_lower, dtype=float), np.asarray(lower_model, dtype=float))
        upper = np.minimum(np.asarray(self.joint_position_upper, dtype=float), np.asarray(upper_model, dtype=float))
        return PandaLimits(joint_position_lower=tuple(lower), joint_position_upper=tuple(upper),
                           torque=self.torque, torque_rate=self.torque_rate, joint_velocity=self.joint_velocity,
                           tcp_speed=self.tcp_speed)


#: Franka Emika Panda ("FER"): franka_description robots/fer/joint_limits.yaml (positions, 2.175/2.61 rad/s,
#: 87/12 N m), libfranka's Panda rate_limiting.h (1000 N m/s, 1.7 m/s).
PANDA = ArmProfile(
    name="panda", joint_prefix="panda",
    joint_position_lower=(-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973),
    joint_position_upper=(2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973),
    joint_velocity=(2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61),
    torque=(87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0), torque_rate=1000.0, tcp_speed=1.7,
    source="franka_description robots/fer/joint_limits.yaml; libfranka rate_limiting.h (Panda)")

#: Franka Research 3: franka_description robots/fr3/joint_limits.yaml (positions, velocities, efforts: the FR3
#: datasheet's "Limits for Franka Research 3"), libfranka's FR3 rate_limiting.h (torque rate 1000 N m/s,
#: translational velocity 3.0 m/s).
FR3 = ArmProfile(
    name="fr3", joint_prefix="fr3",
    joint_position_lower=(-2.7437, -1.7837, -2.9007, -3.0421, -2.8065, 0.5445, -3.0159),
    joint_position_upper=(2.7437, 1.7837, 2.9007, -0.1518, 2.8065, 4.5169, 3.0159),
    joint_velocity=(2.62, 2.62, 2.62, 2.62, 5.26, 4.18, 5.26),
    torque=(87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0), torque_rate=1000.0, tcp_speed=3.0,
    source="franka_description robots/fr3/joint_limits.yaml; libfranka rate_limiting.h (FR3)")

_PROFILES = {"panda": PANDA, "fr3": FR3}


def arm_profile(name: str) -> ArmProfile:
    """The profile of ``name`` (one of ARM_TYPES); FicInputError otherwise."""
    try:
        return _PROFILES[name]
    except KeyError:
        raise FicInputError(f"arm_type must be one of {ARM_TYPES}, got {name!r}") from None


def resolve_joint_names(profile: ArmProfile, joint_names: list[str] | tuple[str, ...] | None = None,
                        joint_prefix: str = "") -> tuple[str, ...]:
    """The names the replica expects: an explicit list of 7 wins, then a prefix, then the arm's own prefix."""
    names = tuple(name for name in (joint_names or ()) if name)
    if names:
        if len(names) != 7 or len(set(names)) != 7:
            raise FicInputError(f"joint_names must be 7 distinct names (joints 1..7 in order), got {list(names)}")
        return names
    return profile.joint_names(joint_prefix or None)
