"""geometry_msgs fields <-> the plain tuples and arrays fic_core takes and returns."""
from __future__ import annotations

from collections.abc import Sequence

from geometry_msgs.msg import Pose


def xyz(vector) -> tuple[float, float, float]:
    """A Vector3 or Point as (x, y, z)."""
    return vector.x, vector.y, vector.z


def xyzw(quaternion) -> tuple[float, float, float, float]:
    """A geometry_msgs Quaternion as (x, y, z, w), the order pinocchio.Quaternion's coeffs() use."""
    return quaternion.x, quaternion.y, quaternion.z, quaternion.w


def set_xyz(vector, values: Sequence[float]) -> None:
    """Write three numbers into a Vector3 or Point (as Python floats: the message refuses numpy scalars)."""
    vector.x, vector.y, vector.z = (float(v) for v in values)


def set_pose(pose: Pose, position: Sequence[float], orientation_xyzw: Sequence[float]) -> None:
    set_xyz(pose.position, position)
    o = pose.orientation
    o.x, o.y, o.z, o.w = (float(v) for v in orientation_xyzw)
