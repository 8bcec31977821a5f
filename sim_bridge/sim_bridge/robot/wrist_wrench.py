"""The wrist force/torque reading: what the environment applies to the end-effector, at the TCP, in the base frame.

Why not a MuJoCo force/torque sensor: a site sensor between flange and hand measures the hand's own weight and
inertial forces too, which a real Franka's external-wrench estimate removes and which the master must not feel
(paper Eq. 3 feeds back the interaction force F_R). Summing what touches the end-effector gives exactly the
interaction: every contact force on the hand, the fingers and the plate (all one rigid body with the hand), from
``mj_contactForce``, plus the adhesive bond's weld force on the hand, each moved to the TCP point.

Contact convention (checked in the tests): the contact frame's first row is the normal pointing from geom1 to
geom2, and ``mj_contactForce`` gives the force geom1 applies to geom2 in that frame.
"""
from __future__ import annotations

import mujoco
import numpy as np


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """3-vector cross product; numpy's general np.cross costs about 20x more, and this runs at 1 kHz."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


class WristWrench:
    """Computes the environment's wrench on the end-effector bodies, expressed at the TCP in the world frame."""

    def __init__(self, model: mujoco.MjModel, end_effector_bodies: tuple[str, ...]) -> None:
        ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) for name in end_effector_bodies]
        if min(ids) < 0:
            raise ValueError(f"unknown end-effector body among {end_effector_bodies}")
        # Python sets and lists, not numpy: with tens of contacts, per-call numpy overhead dominates at 1 kHz.
        self._end_effector_geoms = {g for g in range(model.ngeom) if model.geom_bodyid[g] in ids}
        self._contact_wrench = np.zeros(6)

    def contact_wrench(self, model: mujoco.MjModel, data: mujoco.MjData, tcp_position: np.ndarray) -> np.ndarray:
        """Sum of contact forces on the end-effector, (fx, fy, fz, tx, ty, tz) about ``tcp_position``."""
        total = np.zeros(6)
        count = data.ncon
        if count == 0:
            return total
        contacts = data.contact
        geom1, geom2 = contacts.geom1.tolist(), contacts.geom2.tolist()
        end_effector = self._end_effector_geoms
        # Exactly one side on the end-effector (internal contacts exert no net force); most steps have none, and
        # then the constraint rows are not read.
        touching = [i for i in range(count) if (geom1[i] in end_effector) != (geom2[i] in end_effector)]
        if not touching:
            return total
        active = contacts.efc_address.tolist()
        for i in touching:
            if active[i] < 0:   # only contacts with constraint rows (excluded or inactive ones carry no force)
                continue
            mujoco.mj_contactForce(model, data, i, self._contact_wrench)
            frame = contacts.frame[i].reshape(3, 3)
            force = frame.T @ self._contact_wrench[:3]  # on geom2, world frame
            torque = frame.T @ self._contact_wrench[3:]
            if geom1[i] in end_effector:  # the end-effector is geom1: it receives the reaction
                force, torque = -force, -torque
            total[:3] += force
            total[3:] += torque + cross(contacts.pos[i] - tcp_position, force)
        return total
