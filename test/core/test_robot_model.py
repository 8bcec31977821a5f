"""RobotModel: the TCP Jacobian against finite differences of the TCP pose, and the dynamics identities."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from fic_core.errors import FicInputError
from fic_core.panda_description import JOINT_ARMATURE, JOINT_DAMPING, NOMINAL_CONFIGURATION
from fic_core.robot_model import RobotModel


def random_configuration(robot: RobotModel, rng: np.random.Generator) -> np.ndarray:
    return rng.uniform(robot.lower_position_limit, robot.upper_position_limit)


def tcp_pose(robot: RobotModel, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    robot.update(q, np.zeros(7))
    return robot.tcp_position.copy(), robot.tcp_rotation.copy()


def test_joint_limits_come_from_the_urdf(robot: RobotModel) -> None:
    assert robot.dof == 7
    np.testing.assert_allclose(robot.lower_position_limit,
                               [-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
    np.testing.assert_allclose(robot.upper_position_limit,
                               [2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
    np.testing.assert_allclose(robot.urdf_effort_limit, [87, 87, 87, 87, 12, 12, 12])
    np.testing.assert_allclose(robot.joint_damping, JOINT_DAMPING)


def test_tcp_jacobian_matches_finite_differences_of_the_pose(robot: RobotModel) -> None:
    rng = np.random.default_rng(1)
    step = 1e-6
    for _ in range(20):
        q = random_configuration(robot, rng)
        robot.update(q, np.zeros(7))
        jacobian = robot.tcp_jacobian.copy()
        numeric = np.zeros((6, 7))
        for i in range(7):
            dq = np.zeros(7)
            dq[i] = step
            p_plus, r_plus = tcp_pose(robot, q + dq)
            p_minus, r_minus = tcp_pose(robot, q - dq)
            numeric[:3, i] = (p_plus - p_minus) / (2 * step)
            # Base-frame angular velocity: R(q+h) = exp(w h) R(q)  ->  w = log3(R+ R-^T) / 2h.
            numeric[3:, i] = pin.log3(r_plus @ r_minus.T) / (2 * step)
        np.testing.assert_allclose(jacobian, numeric, atol=1e-7)


def test_tcp_twist_is_the_derivative_of_the_pose_along_a_motion(robot: RobotModel) -> None:
    rng = np.random.default_rng(2)
    q = random_configuration(robot, rng)
    qd = rng.normal(size=7)
    robot.update(q, qd)
    twist = robot.tcp_twist.copy()
    speed = robot.tcp_speed
    h = 1e-6
    p_plus, r_plus = tcp_pose(robot, q + h * qd)
    p_minus, r_minus = tcp_pose(robot, q - h * qd)
    np.testing.assert_allclose(twist[:3], (p_plus - p_minus) / (2 * h), atol=1e-7)
    np.testing.assert_allclose(twist[3:], pin.log3(r_plus @ r_minus.T) / (2 * h), atol=1e-7)
    assert speed == pytest.approx(np.linalg.norm(twist[:3]))


def test_dynamics_identities(robot: RobotModel) -> None:
    """M symmetric and inverted by Minv; C qd + g is RNEA at zero acceleration; M a + h = RNEA(q, qd, a)."""
    rng = np.random.default_rng(3)
    data = robot.model.createData()
    for _ in range(50):
        q = random_configuration(robot, rng)
        qd = rng.normal(size=7)
        acceleration = rng.normal(size=7)
        robot.update(q, qd)
        mass = robot.mass_matrix
        np.testing.assert_allclose(mass, mass.T, atol=1e-12)
        np.testing.assert_allclose(robot.mass_matrix_inverse, robot.mass_matrix_inverse.T, atol=1e-10)
        np.testing.assert_allclose(mass @ robot.mass_matrix_inverse, np.eye(7), atol=1e-9)
        assert np.all(np.diag(mass) > JOINT_ARMATURE)  # the armature is in M
        np.testing.assert_allclose(robot.gravity, pin.rnea(robot.model, data, q, np.zeros(7), np.zeros(7)), atol=1e-10)
        np.testing.assert_allclose(robot.nonlinear_effects, robot.coriolis + robot.gravity, atol=1e-12)
        np.testing.assert_allclose(mass @ acceleration + robot.nonlinear_effects,
                                   pin.rnea(robot.model, data, q, qd, acceleration), atol=1e-9)
        assert robot.kinetic_energy == pytest.approx(0.5 * qd @ mass @ qd, rel=1e-10)
        # C(q, qd) qd is quadratic in qd.
        robot.update(q, 2 * qd)
        coriolis_double = robot.coriolis.copy()
        robot.update(q, qd)
        np.testing.assert_allclose(coriolis_double, 4 * robot.coriolis, atol=1e-9)


def test_nominal_configuration_is_inside_the_limits(robot: RobotModel) -> None:
    assert np.all(robot.joint_position_margin(NOMINAL_CONFIGURATION) > 0.3)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_state_is_rejected(robot: RobotModel, bad: float) -> None:
    q = NOMINAL_CONFIGURATION.copy()
    q[3] = bad
    with pytest.raises(FicInputError, match="q"):
        robot.update(q, np.zeros(7))
    qd = np.zeros(7)
    qd[6] = bad
    with pytest.raises(FicInputError, match="qd"):
        robot.update(NOMINAL_CONFIGURATION, qd)


def test_wrong_shape_is_rejected(robot: RobotModel) -> None:
    with pytest.raises(FicInputError, match="shape"):
        robot.update(np.zeros(6), np.zeros(7))


def test_reading_before_update_is_an_error() -> None:
    with pytest.raises(RuntimeError, match="update"):
        _ = RobotModel().tcp_position


def test_update_returns_the_state_the_accessors_read(robot: RobotModel) -> None:
    """``update`` returns ``robot.state`` (one object, refilled): its fields are what the accessors return, and the
    float lists are q and qd."""
    rng = np.random.default_rng(5)
    q, qd = random_configuration(robot, rng), rng.normal(scale=0.3, size=7)
    state = robot.update(q, qd)
    assert state is robot.state
    for field, accessor in (("q", "q"), ("qd", "qd"), ("tcp_position", "tcp_position"),
                            ("tcp_rotation", "tcp_rotation"), ("tcp_jacobian", "tcp_jacobian"),
                            ("tcp_twist", "tcp_twist"), ("mass_matrix_inverse", "mass_matrix_inverse"),
                            ("nonlinear_effects", "nonlinear_effects")):
        assert getattr(state, field) is getattr(robot, accessor), field
    assert state.q_values == q.tolist() and state.qd_values == qd.tolist()
    np.testing.assert_allclose(state.tcp_twist, state.tcp_jacobian @ qd, rtol=1e-12, atol=1e-15)
    assert robot.update(NOMINAL_CONFIGURATION, np.zeros(7)) is state
    np.testing.assert_array_equal(state.q, NOMINAL_CONFIGURATION)
