"""A small Cartesian impedance law on MuJoCo's own Jacobian, for driving the simulated arm in the sim tests.

Test scaffolding only (the real controller is fic_core's FIC): tau = bias + J^T (K e - D v + F) - D_null qd.
"""
from __future__ import annotations

import mujoco
import numpy as np

from sim_bridge.robot.mujoco_panda import PandaSimulation


def rotation_error(rotation: np.ndarray, desired: np.ndarray) -> np.ndarray:
    """Small-angle rotation vector taking ``rotation`` to ``desired`` (world frame)."""
    return 0.5 * sum(np.cross(rotation[:, i], desired[:, i]) for i in range(3))


def cartesian_torque(sim: PandaSimulation, position: np.ndarray, rotation: np.ndarray, force: np.ndarray | None = None,
                     stiffness: np.ndarray | None = None, rotational_stiffness: float = 30.0,
                     damping: float = 40.0, rotational_damping: float = 3.0) -> np.ndarray:
    """A Cartesian spring-damper's joint torques (gravity compensated), pushing with ``force`` (default none),
    translational ``stiffness`` 400 N/m an axis by default."""
    force = np.zeros(3) if force is None else force
    stiffness = np.array([400.0, 400.0, 400.0]) if stiffness is None else stiffness
    model, data = sim.model, sim.data
    jacp = np.zeros((3, model.nv))
    jacr = np.zeros((3, model.nv))
    mujoco.mj_jacSite(model, data, jacp, jacr, model.site("tcp").id)
    jacobian = np.vstack([jacp[:, :7], jacr[:, :7]])
    qd = sim.joint_velocities
    twist = jacobian @ qd
    tcp_position, tcp_rotation = sim.tcp_pose
    wrench = np.concatenate([
        stiffness * (position - tcp_position) - damping * twist[:3] + force,
        rotational_stiffness * rotation_error(tcp_rotation, rotation) - rotational_damping * twist[3:],
    ])
    return data.qfrc_bias[:7] + jacobian.T @ wrench - 0.5 * qd
