"""Null-space posture of the replica: the tau_posture term added to paper Eq. 7.

The arm has 7 joints for a 6-D task, so one motion (the elbow's self-motion) is not held by the Cartesian FIC;
left alone it wanders (seen here) and drifts toward the joint limits. This term pulls the arm toward
``NOMINAL_CONFIGURATION`` (Franka's well-conditioned "ready" pose), damps the self-motion, and pushes joints
away from their URDF limits inside a band near them.

Projection: dynamically consistent (Khatib). The torque is filtered by

    N^T = I - J^T Lambda J M^-1 ,   Lambda = (J M^-1 J^T)^-1

so that it produces no TCP acceleration at all: J M^-1 tau_posture = 0. The simpler projector
I - J^T (J^T)^+ only makes the torque orthogonal to J^T's range; through the inertia coupling it would still
accelerate the TCP and so inject energy into the task space, where the FIC's energy bound is argued (Eq. 2).
With the consistent projector the FIC's task-space behaviour is exactly that of Eq. 2, whatever the posture does.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg.lapack import dposv  # a 6x6 Cholesky solve without numpy.linalg's per-call overhead

from .errors import FicInputError, finite_array, finite_scalar
from .panda_description import NOMINAL_CONFIGURATION


def _gain(name: str, value: float | ArrayLike, dof: int) -> NDArray[np.float64]:
    array = np.broadcast_to(finite_array(name, value), (dof,)).astype(float)
    if np.any(array < 0.0):
        raise FicInputError(f"{name} must be >= 0, got {value}")
    return array


class NullSpacePosture:
    """Joint-space posture torque, projected into the dynamically consistent null space of the TCP task.

    Parameters
    ----------
    lower_limit, upper_limit:
        Joint position limits [rad] (the URDF's, from ``RobotModel``).
    stiffness:
        Pull toward ``nominal`` [N m / rad], scalar or per joint.
    damping:
        Joint damping of the self-motion [N m s / rad], scalar or per joint.
    limit_band:
        Width of the band near each joint limit where the repulsion acts [rad].
    limit_stiffness:
        Repulsion gain [N m / rad]: the torque grows as ``limit_stiffness * (band - d)^2 / band`` (zero with zero
        slope at the band's edge, ``limit_stiffness * band`` at the limit).
    task_regularisation:
        Added to J M^-1 J^T before inversion so that a near-singular TCP Jacobian cannot blow the projector up.
    """

    def __init__(self, lower_limit: ArrayLike, upper_limit: ArrayLike, *,
                 nominal: ArrayLike = NOMINAL_CONFIGURATION, stiffness: float | ArrayLike = 10.0,
                 damping: float | ArrayLike = 2.0, limit_band: float = 0.2, limit_stiffness: float = 50.0,
                 task_regularisation: float = 1e-8) -> None:
        self.lower_limit = finite_array("lower_limit", lower_limit)
        dof = self.lower_limit.size
        self.upper_limit = finite_array("upper_limit", upper_limit, (dof,))
        if np.any(self.lower_limit >= self.upper_limit):
            raise FicInputError("lower_limit must be below upper_limit for every joint")
        self.nominal = finite_array("nominal", nominal, (dof,))
        self.stiffness = _gain("stiffness", stiffness, dof)
        self.damping = _gain("damping", damping, dof)
        self.limit_band = finite_scalar("limit_band", limit_band, minimum=0.0, minimum_inclusive=False)
        self.limit_stiffness = finite_scalar("limit_stiffness", limit_stiffness, minimum=0.0)
        self.task_regularisation = finite_scalar("task_regularisation", task_regularisation, minimum=0.0)
        self.dof = dof
        self._regularisation_matrix = self.task_regularisation * np.eye(6)
        # The gains as Python floats for the per-joint arithmetic of the replica's tick (``joint_torque_values``);
        # the parameters are fixed at construction.
        self._nominal_values = self.nominal.tolist()
        self._stiffness_values = self.stiffness.tolist()
        self._damping_values = self.damping.tolist()

    def limit_repulsion(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """Joint torque pushing each joint out of the band near its limits (zero outside the band)."""
        band = self.limit_band
        depth_low = np.maximum(band - (q - self.lower_limit), 0.0)  # > 0 inside the band at the lower limit
        depth_high = np.maximum(band - (self.upper_limit - q), 0.0)
        return self.limit_stiffness / band * (depth_low * depth_low - depth_high * depth_high)

    def joint_torque(self, q: NDArray[np.float64], qd: NDArray[np.float64],
                     position_margin: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """The posture torque before projection: spring to nominal, damping, limit repulsion.

        ``position_margin`` (distance to the nearest limit per joint), if the caller has it, lets the repulsion
        be skipped when no joint is inside the band.
        """
        torque = self.stiffness * (self.nominal - q) - self.damping * qd
        if position_margin is None or position_margin.min() < self.limit_band:
            torque += self.limit_repulsion(q)
        return torque

    def joint_torque_values(self, q_values: list[float], qd_values: list[float], q: NDArray[np.float64],
                            smallest_margin: float) -> list[float]:
        """``joint_torque`` on validated floats (the replica's tick): the same terms, as a list of floats.

        ``q_values``, ``qd_values`` are q and qd as Python floats, ``q`` the same q as an array (for the limit
        repulsion), ``smallest_margin`` the smallest distance of a joint to its position limits [rad].
        """
        torque = [stiffness * (nominal - position) - damping * velocity
                  for stiffness, nominal, position, damping, velocity in zip(
                      self._stiffness_values, self._nominal_values, q_values, self._damping_values, qd_values)]
        if smallest_margin < self.limit_band:
            torque = [value + repulsion for value, repulsion in zip(torque, self.limit_repulsion(q).tolist())]
        return torque

    def projector(self, jacobian: NDArray[np.float64], mass_matrix_inverse: NDArray[np.float64]) -> NDArray[np.float64]:
        """N^T = I - J^T Lambda J M^-1, the dynamically consistent null-space projector for torques (7 x 7)."""
        j_minv = jacobian @ mass_matrix_inverse                      # J M^-1 (6 x 7)
        lambda_j_minv = self.apply_task_inertia(j_minv @ jacobian.T, j_minv)  # Lambda J M^-1 (6 x 7)
        return np.eye(self.dof) - jacobian.T @ lambda_j_minv

    def project(self, torque: NDArray[np.float64], jacobian: NDArray[np.float64],
                mass_matrix_inverse: NDArray[np.float64]) -> NDArray[np.float64]:
        """N^T torque, without forming N^T: torque - J^T Lambda (J M^-1 torque)."""
        j_minv = jacobian @ mass_matrix_inverse
        return torque - jacobian.T @ self.apply_task_inertia(j_minv @ jacobian.T, j_minv @ torque)

    def apply_task_inertia(self, task_inverse_inertia: NDArray[np.float64],
                           rhs: NDArray[np.float64]) -> NDArray[np.float64]:
        """Lambda rhs = (J M^-1 J^T + eps I)^-1 rhs, by Cholesky (J M^-1 J^T is symmetric positive semidefinite):
        the operational-space inertia Lambda, regularised by ``task_regularisation``, applied to a (6,) or (6, n)
        ``rhs``, given ``task_inverse_inertia`` = J M^-1 J^T."""
        matrix = task_inverse_inertia + self._regularisation_matrix
        _, solution, info = dposv(matrix, rhs)
        if info != 0:  # not positive definite: only if the regularisation is zero at an exact singularity
            solution = np.linalg.lstsq(matrix, rhs, rcond=None)[0]
        return solution

    def torque(self, q: ArrayLike, qd: ArrayLike, jacobian: ArrayLike, mass_matrix_inverse: ArrayLike,
               position_margin: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """tau_posture = N^T (K (q_nominal - q) - D qd + repulsion(q)): no TCP acceleration (J M^-1 tau = 0)."""
        q = np.asarray(q, dtype=float)
        qd = np.asarray(qd, dtype=float)
        return self.project(self.joint_torque(q, qd, position_margin), np.asarray(jacobian, dtype=float),
                            np.asarray(mass_matrix_inverse, dtype=float))
