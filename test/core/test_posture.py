"""Null-space posture: dynamically consistent (no TCP acceleration), pulls toward nominal, repels limits."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.errors import FicInputError
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.posture import NullSpacePosture
from fic_core.robot_model import RobotModel


@pytest.fixture(scope="module")
def posture(robot: RobotModel) -> NullSpacePosture:
    return NullSpacePosture(robot.lower_position_limit, robot.upper_position_limit)


def well_conditioned_states(robot: RobotModel, count: int, seed: int):
    """Random states whose TCP Jacobian is far from singular (smallest singular value > 0.05)."""
    rng = np.random.default_rng(seed)
    found = 0
    while found < count:
        q = rng.uniform(robot.lower_position_limit, robot.upper_position_limit)
        qd = rng.normal(size=7)
        robot.update(q, qd)
        if np.linalg.svd(robot.tcp_jacobian, compute_uv=False)[-1] > 0.05:
            found += 1
            yield q, qd


def test_posture_torque_produces_no_tcp_acceleration(robot: RobotModel, posture: NullSpacePosture) -> None:
    for q, qd in well_conditioned_states(robot, 200, seed=4):
        jacobian, minv = robot.tcp_jacobian, robot.mass_matrix_inverse
        torque = posture.torque(q, qd, jacobian, minv)
        raw = posture.joint_torque(q, qd)
        task_acceleration = jacobian @ minv @ torque
        # Relative to what the unprojected torque would do to the TCP.
        assert np.linalg.norm(task_acceleration) <= 1e-5 * max(1.0, np.linalg.norm(jacobian @ minv @ raw))


def test_projector_properties(robot: RobotModel, posture: NullSpacePosture) -> None:
    """N^T is idempotent, annihilates task forces (N^T J^T = 0) and matches the vector form."""
    rng = np.random.default_rng(5)
    for _q, _qd in well_conditioned_states(robot, 50, seed=6):
        jacobian, minv = robot.tcp_jacobian, robot.mass_matrix_inverse
        projector = posture.projector(jacobian, minv)
        np.testing.assert_allclose(projector @ projector, projector, atol=1e-5)
        np.testing.assert_allclose(projector @ jacobian.T, np.zeros((7, 6)), atol=1e-5)
        torque = rng.normal(size=7)
        np.testing.assert_allclose(posture.project(torque, jacobian, minv), projector @ torque, atol=1e-9)


def test_posture_pulls_toward_nominal(robot: RobotModel, posture: NullSpacePosture) -> None:
    """At rest the projected pull does non-negative work toward nominal: (q_nom - q)^T M^-1 tau_posture >= 0,
    since M^-1 N^T is positive semidefinite."""
    for q, _ in well_conditioned_states(robot, 100, seed=7):
        robot.update(q, np.zeros(7))
        torque = posture.torque(q, np.zeros(7), robot.tcp_jacobian, robot.mass_matrix_inverse)
        if np.all(robot.joint_position_margin(q) > posture.limit_band):
            assert (NOMINAL_CONFIGURATION - q) @ robot.mass_matrix_inverse @ torque >= -1e-9
    # At nominal, at rest, there is nothing to do.
    robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    np.testing.assert_allclose(posture.torque(NOMINAL_CONFIGURATION, np.zeros(7), robot.tcp_jacobian,
                                              robot.mass_matrix_inverse), 0.0, atol=1e-12)


def test_posture_damps_self_motion(robot: RobotModel, posture: NullSpacePosture) -> None:
    """At nominal, a self-motion velocity is opposed: qd^T tau_posture < 0."""
    robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    _, _, vt = np.linalg.svd(robot.tcp_jacobian)
    self_motion = vt[-1]  # J self_motion = 0
    robot.update(NOMINAL_CONFIGURATION, self_motion)
    torque = posture.torque(NOMINAL_CONFIGURATION, self_motion, robot.tcp_jacobian, robot.mass_matrix_inverse)
    assert self_motion @ torque < 0.0


def test_limit_repulsion(robot: RobotModel, posture: NullSpacePosture) -> None:
    band = posture.limit_band
    lower, upper = robot.lower_position_limit, robot.upper_position_limit
    # Outside the band: nothing.
    np.testing.assert_array_equal(posture.limit_repulsion(NOMINAL_CONFIGURATION), 0.0)
    # Inside the band: away from the limit, growing toward it, limit_stiffness * band at the limit.
    for depth in (0.25, 0.5, 1.0):
        q = NOMINAL_CONFIGURATION.copy()
        q[0] = upper[0] - band * (1 - depth)
        q[3] = lower[3] + band * (1 - depth)
        repulsion = posture.limit_repulsion(q)
        assert repulsion[0] == pytest.approx(-posture.limit_stiffness * band * depth ** 2)
        assert repulsion[3] == pytest.approx(posture.limit_stiffness * band * depth ** 2)
        assert np.count_nonzero(repulsion) == 2
    # Continuous at the band's edge.
    q = NOMINAL_CONFIGURATION.copy()
    q[0] = upper[0] - band + 1e-9
    assert abs(posture.limit_repulsion(q)[0]) < 1e-12


def test_invalid_parameters_are_rejected(robot: RobotModel) -> None:
    lower, upper = robot.lower_position_limit, robot.upper_position_limit
    with pytest.raises(FicInputError, match="stiffness"):
        NullSpacePosture(lower, upper, stiffness=-1.0)
    with pytest.raises(FicInputError, match="damping"):
        NullSpacePosture(lower, upper, damping=float("nan"))
    with pytest.raises(FicInputError, match="limit_band"):
        NullSpacePosture(lower, upper, limit_band=0.0)
    with pytest.raises(FicInputError, match="nominal"):
        NullSpacePosture(lower, upper, nominal=np.zeros(6))
    with pytest.raises(FicInputError, match="below"):
        NullSpacePosture(upper, lower)
