"""The task inertia Lambda = (J M^-1 J^T + eps I)^-1 with eps = 0 at an exact singularity, whichever task axis it
is on: a Jacobian whose row k is zero (the TCP cannot move along that axis) makes J M^-1 J^T singular in row and
column k, and the Cholesky fails at the leading minor of order k + 1. For every k, including the first axis (the
failure at order 1), apply_task_inertia falls back to the least-squares solution (the oracle:
numpy.linalg.pinv, the minimum-norm solution), finite, solving the system for a right-hand side in its range."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.posture import NullSpacePosture

LOWER = -np.ones(7)
UPPER = np.ones(7)


@pytest.mark.parametrize("axis", range(6))
def test_a_task_axis_the_tcp_cannot_move_along_falls_back_to_least_squares(axis: int) -> None:
    generator = np.random.default_rng(100 + axis)
    jacobian = generator.normal(size=(6, 7))
    jacobian[axis] = 0.0
    factor = generator.normal(size=(7, 7))
    mass_matrix_inverse = factor @ factor.T + 7.0 * np.eye(7)
    matrix = jacobian @ mass_matrix_inverse @ jacobian.T
    rhs = generator.normal(size=6)
    rhs[axis] = 0.0                                    # in the range of the singular matrix
    posture = NullSpacePosture(LOWER, UPPER, task_regularisation=0.0)
    solution = posture.apply_task_inertia(matrix, rhs)
    assert np.all(np.isfinite(solution))
    np.testing.assert_allclose(solution, np.linalg.pinv(matrix) @ rhs, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(matrix @ solution, rhs, atol=1e-9)
