"""The arm's own stop when a joint moves faster than its datasheet allows, whatever its controller commands.

A Franka arm does not leave this to the user's controller: its control unit stops the arm with the error
``joint_velocity_violation`` (libfranka's ``franka::Errors``) and takes no torque command until the error is
recovered. The simulated arm does the same, so that a controller that goes wrong (a replica starved of CPU that
sends a stale torque every 15-170 ms: docs/RESULTS.md, "Faults and hostile input") meets the limit a real arm would
put in its way, not a simulated arm that swings on at 11 rad/s. Once tripped the reflex latches for the rest of the
run: the robot applies its hold torque (gravity and Coriolis compensation plus damping, the stale-command
watchdog's) at every physics step and ignores the commands; on a real arm its brakes would engage.

The threshold is the arm profile's joint velocity limit (fic_core.arm_profile: Panda by default, FR3 behind
franka_ros2) plus REFLEX_MARGIN. At the limit itself a torque-controlled arm overshoots for a step now and then
(2.616 against 2.61 rad/s in a quiet two-station cut run, 2026-12-04): that is a violation for the replica to count
and the launcher to report (exit 3), not a reason to stop the arm. A runaway passes the margin within a few steps
(the one that set this up reached 11 rad/s).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from fic_core.errors import FicInputError
from fic_core.limits import VIOLATION_TOLERANCE

REFLEX_MARGIN = 0.10   # the reflex trips above (1 + REFLEX_MARGIN) x the datasheet speed (module docstring)


@dataclass(frozen=True)
class ReflexEvent:
    time: float        # when the reflex tripped (the caller's clock)
    joint: str         # the joint that moved too fast (the first, if several)
    velocity: float    # its measured velocity [rad/s]
    limit: float       # its limit [rad/s]
    message: str


class VelocityReflex:
    """Latches when a measured joint velocity exceeds its limit (module docstring)."""

    def __init__(self, joint_velocity_limits: ArrayLike, joint_names: Sequence[str]) -> None:
        limits = np.asarray(joint_velocity_limits, dtype=float)
        if limits.ndim != 1 or limits.size != len(joint_names) or not np.all(np.isfinite(limits)) \
                or np.any(limits <= 0.0):
            raise FicInputError(f"joint velocity limits must be one positive number per joint "
                                f"({len(joint_names)}), got {joint_velocity_limits!r}")
        self._bounds = limits * (1.0 + REFLEX_MARGIN) + VIOLATION_TOLERANCE
        self._limits = limits
        self._names = tuple(joint_names)
        self.event: ReflexEvent | None = None

    @property
    def tripped(self) -> bool:
        return self.event is not None

    def check(self, joint_velocities: ArrayLike, time: float) -> ReflexEvent | None:
        """Call at every physics step with the measured joint velocities; returns the event once, when it trips.
        A NaN velocity trips it too (the state is not known to be inside the limits)."""
        if self.event is not None:
            return None
        velocities = np.abs(np.asarray(joint_velocities, dtype=float))
        inside = velocities <= self._bounds   # False for NaN
        if inside.all():
            return None
        joint = int(np.argmin(inside))
        self.event = ReflexEvent(
            time, self._names[joint], float(velocities[joint]), float(self._limits[joint]),
            f"reflex: {self._names[joint]} moved at {velocities[joint]:.3f} rad/s, beyond its limit "
            f"{self._limits[joint]:.3f} rad/s by more than {REFLEX_MARGIN:.0%} (a Franka arm stops with "
            "joint_velocity_violation): holding the arm "
            "(gravity compensation + damping) and ignoring torque commands until the robot is restarted")
        return self.event
