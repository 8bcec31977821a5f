"""Quaternions as ROS writes them (x, y, z, w): checked once, normalised and turned into rotations by Pinocchio.

One home for the two jobs every orientation input needs (the planner's fixed orientation, the replica's desired
rotation, the haptic device's mounting), so that the check and its message are the same everywhere."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from fic_core.errors import FicInputError

#: Below this norm a quaternion has no direction to normalise to (a zeroed or uninitialised message).
MIN_NORM = 1e-6


def unit_quaternion(values: ArrayLike, name: str = "orientation") -> tuple[float, float, float, float]:
    """``values`` [x, y, z, w] normalised: a value written by hand (0.7071 for 1/sqrt(2)) is a rotation only up to
    its rounding. FicInputError unless four finite numbers of non-zero norm."""
    try:
        quaternion = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        quaternion = np.empty(0)
    if (quaternion.shape != (4,) or not np.all(np.isfinite(quaternion))
            or float(np.linalg.norm(quaternion)) < MIN_NORM):
        raise FicInputError(f"{name} must be a quaternion [x, y, z, w] of shape (4,), finite, with a non-zero norm, "
                            f"got {values!r}")
    x, y, z, w = pin.Quaternion(quaternion).normalized().coeffs().tolist()  # Eigen's coeffs are (x, y, z, w)
    return x, y, z, w


def rotation_from_quaternion(values: ArrayLike, name: str = "desired_rotation") -> NDArray[np.float64]:
    """The rotation matrix of a quaternion [x, y, z, w] (normalised first; FicInputError as unit_quaternion)."""
    x, y, z, w = unit_quaternion(values, name)
    return pin.Quaternion(w, x, y, z).toRotationMatrix()
