"""The replica's F_R from a wrench sensor or estimator: checked frame, sign convention, reference point.

The master renders K_H F_R with F_R the force the environment applies to the replica's TCP, in the replica's base
frame (paper Eq. 3). The simulated wrist sensor publishes exactly that (frame ``panda_link0``). franka_ros2's
``franka_robot_state_broadcaster/external_wrench_in_base_frame`` is libfranka's O_F_ext_hat_K: the estimated
external wrench on the stiffness frame K, expressed in the base frame (frame_id: the URDF's root link, ``base``
in franka_bringup's description). So three things are declared, not assumed:

- which frame_ids are the base frame (a wrench in any other frame is refused: rotating it would need a
  transform this node does not have, and a wrench taken in the wrong frame would push the operator's hand the
  wrong way);
- its sign: +1 if it is the wrench of the environment on the robot (libfranka's wording), -1 if it is the
  robot's on the environment (docs/HARDWARE.md: reports disagree on the real arm's sign; the bring-up
  checklist measures it);
- where K is relative to the TCP (zero when K is the hand's TCP, franka_ros2's default with the Franka Hand):
  the moment is moved to the TCP, m_TCP = m_K + (p_K - p_TCP) x f. The force is the same at every point.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_array


@dataclass(frozen=True)
class WrenchFrame:
    """How to read a WrenchStamped as F_R (the environment's wrench on the TCP, base frame)."""

    base_frame_ids: tuple[str, ...] = ("panda_link0",)
    sign: float = 1.0
    reference_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)  # p_K - p_TCP in the TCP frame [m]

    def __post_init__(self) -> None:
        if self.sign not in (1.0, -1.0):
            raise FicInputError(f"wrench sign must be +1 or -1, got {self.sign}")
        if not self.base_frame_ids or not all(self.base_frame_ids):
            raise FicInputError(f"at least one non-empty base frame id is needed, got {list(self.base_frame_ids)}")
        object.__setattr__(self, "reference_offset",
                           tuple(float(v) for v in finite_array("reference_offset", self.reference_offset, (3,))))

    def at_tcp(self, frame_id: str, force: ArrayLike, torque: ArrayLike,
               tcp_rotation: NDArray[np.float64] | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(force, moment about the TCP), base frame. FicInputError for another frame_id or non-finite values.

        ``tcp_rotation`` (base <- TCP) turns the reference offset into the base frame; it is needed only when the
        offset is not zero."""
        if frame_id not in self.base_frame_ids:
            raise FicInputError(f"wrench in frame {frame_id!r}, expected one of {list(self.base_frame_ids)} "
                                "(the base frame)")
        force = self.sign * finite_array("force", force, (3,))
        torque = self.sign * finite_array("torque", torque, (3,))
        offset = np.asarray(self.reference_offset)
        if offset.any():
            if tcp_rotation is None:
                raise FicInputError("a non-zero reference_offset needs the TCP rotation")
            torque = torque + np.cross(np.asarray(tcp_rotation) @ offset, force)
        return force, torque
