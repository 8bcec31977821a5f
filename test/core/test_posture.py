"""Null-space posture: dynamically consistent (no TCP acceleration), pulls toward nominal, repels limits."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.arm_profile import PANDA
from fic_core.errors import FicInputError
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.posture import NullSpacePosture
from fic_core.robot_model import RobotModel

# The Panda's datasheet position limits [rad], and the posture with its defaults: band 0.2 rad, 50 N m / rad.
LOWER, UPPER = np.array(PANDA.joint_position_lower), np.array(PANDA.joint_position_upper)
POSTURE = NullSpacePosture(LOWER, UPPER)


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


def test_the_joint_torque_is_the_spring_the_damper_and_the_repulsion_with_figures(robot: RobotModel) -> None:
    """tau_0 = K (q_nominal - q) - D qd + repulsion(q), per joint, with per-joint gains; the replica's float form
    (``joint_torque_values``) gives the same figures, inside a limit band and outside one."""
    lower, upper = robot.lower_position_limit, robot.upper_position_limit
    stiffness = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0])
    posture = NullSpacePosture(lower, upper, stiffness=stiffness, damping=0.5, limit_band=0.1, limit_stiffness=20.0)
    q = NOMINAL_CONFIGURATION + 0.1
    qd = np.linspace(-0.3, 0.3, 7)
    expected = stiffness * -0.1 - 0.5 * qd
    np.testing.assert_allclose(posture.joint_torque(q, qd), expected, atol=1e-12)
    margin = robot.joint_position_margin(q)
    assert margin.min() > 0.1
    np.testing.assert_allclose(posture.joint_torque_values(q.tolist(), qd.tolist(), q, margin.min()), expected,
                               atol=1e-12)
    # joint 6 (index 5) 0.05 rad from its upper limit, half-way into the band: 20 * 0.05^2 / 0.1 = 0.5 N m back
    q[5] = upper[5] - 0.05
    margin = robot.joint_position_margin(q)
    expected[5] = stiffness[5] * (NOMINAL_CONFIGURATION[5] - q[5]) - 0.5 * qd[5] - 0.5
    for margins in (margin, None):
        np.testing.assert_allclose(posture.joint_torque(q, qd, margins), expected, atol=1e-12)
    np.testing.assert_allclose(posture.joint_torque_values(q.tolist(), qd.tolist(), q, margin.min()), expected,
                               atol=1e-12)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.lists(st.floats(0.0, 1.0), min_size=7, max_size=7), st.lists(st.floats(-2.0, 2.0), min_size=7, max_size=7))
def test_the_float_form_of_the_joint_torque_is_the_array_form_anywhere_in_the_limits(fractions, velocities) -> None:
    """Wherever the joints stand, the band included (the margin given or not), both forms agree."""
    lower, upper = np.array(LOWER), np.array(UPPER)
    q = lower + np.array(fractions) * (upper - lower)
    qd = np.array(velocities)
    margin = np.minimum(q - lower, upper - q)
    reference = POSTURE.joint_torque(q, qd)
    np.testing.assert_allclose(POSTURE.joint_torque(q, qd, margin), reference, atol=1e-12)
    np.testing.assert_allclose(POSTURE.joint_torque_values(q.tolist(), qd.tolist(), q, float(margin.min())),
                               reference, atol=1e-12)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_the_repulsion_grows_toward_each_limit_and_reaches_the_band_times_its_gain(near, nearer) -> None:
    """Inside the band the push is away from the limit, grows (not less) the nearer the joint, is zero at the
    band's edge and limit_stiffness * band at the limit itself; both limits of a joint act on it."""
    lower, upper = np.array(LOWER), np.array(UPPER)
    band, gain = POSTURE.limit_band, POSTURE.limit_stiffness
    near, nearer = sorted((near, nearer))
    for joint in range(7):
        q = np.array(NOMINAL_CONFIGURATION, dtype=float)
        for limit, sign in ((upper[joint], -1.0), (lower[joint], 1.0)):
            pushes = []
            for depth in (near, nearer):
                q[joint] = limit + sign * band * (1.0 - depth)
                pushes.append(sign * POSTURE.limit_repulsion(q)[joint])
            assert 0.0 <= pushes[0] <= pushes[1] <= gain * band * (1 + 1e-12)
            assert pushes[1] == pytest.approx(gain * band * nearer ** 2, rel=1e-9, abs=1e-12)
    q = np.array(NOMINAL_CONFIGURATION, dtype=float)
    q[2] = UPPER[2]
    assert POSTURE.limit_repulsion(q)[2] == pytest.approx(-gain * band)
    # a band wider than half a joint's range: at mid-range both limits push, and cancel
    wide = NullSpacePosture(LOWER, UPPER, limit_band=10.0)
    q[2] = 0.5 * (LOWER[2] + UPPER[2])
    assert wide.limit_repulsion(q)[2] == pytest.approx(0.0, abs=1e-9)
    q[2] = LOWER[2] + 0.1
    assert wide.limit_repulsion(q)[2] > 0.0   # the near limit's push wins


def test_the_task_inertia_solves_the_regularised_system_and_falls_back_at_an_exact_singularity() -> None:
    """Lambda rhs = (J M^-1 J^T + eps I)^-1 rhs for a vector and for columns; with eps = 0 and a singular J M^-1 J^T
    (the Cholesky refuses it) the least-squares solution, finite, instead of a failure."""
    rng = np.random.default_rng(11)
    factor = rng.normal(size=(6, 7))
    matrix = factor @ factor.T
    regularised = NullSpacePosture(LOWER, UPPER, task_regularisation=0.5)
    for rhs in (rng.normal(size=6), rng.normal(size=(6, 4))):
        np.testing.assert_allclose((matrix + 0.5 * np.eye(6)) @ regularised.apply_task_inertia(matrix, rhs), rhs,
                                   atol=1e-9)
    singular = factor[:, :1] @ factor[:, :1].T                     # rank 1
    exact = NullSpacePosture(LOWER, UPPER, task_regularisation=0.0)
    rhs = factor[:, 0] * 2.0                                       # in its range
    solution = exact.apply_task_inertia(singular, rhs)
    assert np.all(np.isfinite(solution))
    np.testing.assert_allclose(singular @ solution, rhs, atol=1e-9)
    np.testing.assert_allclose(solution, np.linalg.lstsq(singular, rhs, rcond=None)[0], atol=1e-12)


def test_at_a_singular_jacobian_the_regularised_projector_stays_bounded(robot: RobotModel) -> None:
    """The arm stretched out (joint 4 at its upper limit near 0, the TCP Jacobian loses rank): the default
    regularisation keeps N^T finite, and it still removes (almost) all of what a task force would do."""
    q = np.array(NOMINAL_CONFIGURATION, dtype=float)
    q[1], q[3] = 0.0, -0.0698
    robot.update(q, np.zeros(7))
    posture = NullSpacePosture(robot.lower_position_limit, robot.upper_position_limit)
    projector = posture.projector(robot.tcp_jacobian, robot.mass_matrix_inverse)
    assert np.all(np.isfinite(projector))
    torque = posture.torque(q, np.ones(7), robot.tcp_jacobian, robot.mass_matrix_inverse)
    assert np.all(np.isfinite(torque)) and np.linalg.norm(torque) < 1e6


@pytest.mark.parametrize("changes, words", [
    ({"limit_stiffness": -1.0}, "limit_stiffness"),
    ({"limit_band": -0.1}, "limit_band"),
    ({"task_regularisation": -1e-9}, "task_regularisation"),
    ({"stiffness": [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, -0.5]}, "stiffness must be >= 0"),
    ({"damping": -2.0}, "damping must be >= 0"),
])
def test_each_parameter_is_checked_with_its_name(changes, words) -> None:
    with pytest.raises(FicInputError, match=words):
        NullSpacePosture(LOWER, UPPER, **changes)


def test_equal_limits_or_a_wrong_number_of_them_are_refused() -> None:
    with pytest.raises(FicInputError, match="below"):
        NullSpacePosture(LOWER, np.where(np.arange(7) == 3, LOWER, UPPER))   # one joint with no range
    with pytest.raises(FicInputError, match="upper_limit"):
        NullSpacePosture(LOWER, UPPER[:6])
    zero = NullSpacePosture(LOWER, UPPER, stiffness=0.0, damping=0.0, limit_stiffness=0.0)
    np.testing.assert_array_equal(zero.joint_torque(np.array(LOWER), np.ones(7)), 0.0)   # all gains may be zero
