"""From a Force Dimension handle (forcedimension_ros2) to the master's x_M, and the master's force back.

forcedimension_ros2 publishes the handle's position in the device's frame ``fd_base`` (its ee_pose_broadcaster,
``/fd/ee_pose``), its velocities only as joint velocities of ``fd_x, fd_y, fd_z`` (joint_state_broadcaster,
``/fd/joint_states``), and takes forces in that same frame as the first three entries of a Float64MultiArray
(``/fd/fd_controller/commands``, an effort JointGroupEffortController over fd_x, fd_y, fd_z [, fd_roll,
fd_pitch, fd_yaw] [, fd_clutch]). The master works in ``haptic_base`` with x_M the handle's displacement from the
workspace centre (paper Eq. 3). The mapping is a fixed rotation R (haptic_base <- fd_base) and the workspace
centre c in fd_base:

    x_M = R (p_fd - c),   xd_M = R v_fd,   f_fd = R^T f_M

On an Omega or Falcon the SDK's origin is the workspace centre (c = 0) and its axes are already x toward the
operator, y right, z up, so R = I; both are parameters for a mounting that differs.

The grasp DoF (an Omega.7's gripper, the driver's joint ``fd_clutch``, an angle in rad) can set K_H: closed
(angle <= ``closed``) gives ``max_gain``, open (angle >= ``open``) gives 0, linear in between: squeezing the
gripper asks for more of the replica's contact force.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_array, finite_scalar
from .quaternion import rotation_from_quaternion


class DeviceFrameMapping:
    """x_M, xd_M from the device frame and f back into it."""

    def __init__(self, rotation_quaternion: ArrayLike = (0.0, 0.0, 0.0, 1.0),
                 workspace_centre: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        self.rotation = rotation_from_quaternion(rotation_quaternion)  # haptic_base <- fd_base, (x, y, z, w)
        self.workspace_centre = finite_array("workspace_centre", workspace_centre, (3,)).copy()

    def position_to_master(self, device_position: ArrayLike) -> NDArray[np.float64]:
        return self.rotation @ (finite_array("device position", device_position, (3,)) - self.workspace_centre)

    def velocity_to_master(self, device_velocity: ArrayLike) -> NDArray[np.float64]:
        return self.rotation @ finite_array("device velocity", device_velocity, (3,))

    def force_to_device(self, master_force: ArrayLike) -> NDArray[np.float64]:
        return self.rotation.T @ finite_array("master force", master_force, (3,))


@dataclass(frozen=True)
class GraspGain:
    """K_H from the gripper angle: ``max_gain`` closed, 0 open, linear in between."""

    open_angle: float = 0.5      # [rad]
    closed_angle: float = 0.05   # [rad]
    max_gain: float = 1.0

    def __post_init__(self) -> None:
        finite_scalar("open_angle", self.open_angle)
        finite_scalar("closed_angle", self.closed_angle)
        finite_scalar("max_gain", self.max_gain, minimum=0.0, maximum=1.0)
        if self.open_angle <= self.closed_angle:
            raise FicInputError(f"grasp open_angle ({self.open_angle}) must be above closed_angle "
                                f"({self.closed_angle})")

    def haptic_gain(self, angle: float) -> float:
        angle = finite_scalar("grasp angle", angle)
        fraction = (self.open_angle - angle) / (self.open_angle - self.closed_angle)
        return self.max_gain * min(1.0, max(0.0, fraction))


def device_command(force: NDArray[np.float64], size: int, max_force: float) -> list[float]:
    """The Float64MultiArray for the driver's effort controller: the force (its norm clipped to ``max_force``),
    then zeros for the controller's other joints (wrist torques, gripper force): ``size`` entries."""
    if size < 3:
        raise FicInputError(f"the device's effort controller needs at least 3 entries (fd_x, fd_y, fd_z), got {size}")
    force = finite_array("device force", force, (3,))
    norm = float(np.linalg.norm(force))
    if max_force > 0.0 and norm > max_force:
        force = force * (max_force / norm)
    return [float(v) for v in force] + [0.0] * (size - 3)
