"""Postural optimisation: never outside the torque/torque-rate box; prediction constraints hold when feasible;
flags set exactly when the command was shaped."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.limits import LimitFlag, PandaLimits
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.postural_optimisation import BRAKING_TORQUE_RAMP, PosturalOptimisation
from fic_core.robot_model import RobotModel

DT = 0.001
TOLERANCE = 1e-9      # [N m] on the hard box
PREDICTION_TOLERANCE = 1e-5  # solver feasibility tolerance, on velocities [rad/s, m/s]
TCP_RELATIVE_TOLERANCE = 1e-6  # the TCP-speed cone is met by a finite number of cutting planes


def shape(optimisation: PosturalOptimisation, robot: RobotModel, q, qd, desired, previous):
    robot.update(q, qd)
    bias = robot.nonlinear_effects + robot.joint_damping * robot.qd
    result = optimisation.shape(np.asarray(desired, dtype=float), previous, robot.q, robot.qd, bias,
                                robot.mass_matrix_inverse, robot.tcp_jacobian[:3])
    return result, bias


def predicted_velocity(optimisation, robot: RobotModel, torque, bias):
    """Joint and TCP velocity extrapolated over the optimisation's horizon, from the model."""
    acceleration = robot.mass_matrix_inverse @ (torque - bias)
    ahead = robot.qd + optimisation.horizon * acceleration
    return ahead, robot.tcp_jacobian[:3] @ ahead


def assert_inside_box(result, previous, limits: PandaLimits, dt: float = DT) -> None:
    assert np.all(np.abs(result.torque) <= limits.torque_array + TOLERANCE)
    if previous is not None:
        assert np.all(np.abs(result.torque - previous) <= limits.torque_rate * dt + TOLERANCE)


#: The Franka Emika Panda datasheet's joint acceleration limits [rad/s^2].
DATASHEET_JOINT_ACCELERATION = (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0)


def test_the_braking_deceleration_is_half_the_datasheet_acceleration_limits(limits) -> None:
    """By default each joint is braked at half its datasheet acceleration limit: v_b L + v_b^2 / (2 a) = room with
    a = a_max / 2 and L = T + the torque ramp, at any room."""
    optimisation = PosturalOptimisation(limits, DT)
    deceleration = np.array(DATASHEET_JOINT_ACCELERATION) / 2.0
    np.testing.assert_array_equal(optimisation.braking_deceleration, deceleration)
    lag = optimisation.horizon + BRAKING_TORQUE_RAMP
    for room in (0.001, 0.05, 0.4):
        q = limits.upper_array - room
        speed = deceleration * (np.sqrt(lag ** 2 + 2.0 * room / deceleration) - lag)
        np.testing.assert_allclose(optimisation.braking_velocity(q)[1], speed, rtol=1e-12)


def test_unconstrained_torque_passes_unchanged(robot, limits) -> None:
    optimisation = PosturalOptimisation(limits, DT)
    robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    gravity = robot.nonlinear_effects.copy()
    desired = gravity + 0.3
    result, _ = shape(optimisation, robot, NOMINAL_CONFIGURATION, np.zeros(7), desired, gravity)
    assert result.flags == LimitFlag.NONE
    assert not result.solved_qp and result.iterations == 0   # the fast path: no solver iterations
    assert result.torque_change == 0.0
    np.testing.assert_array_equal(result.torque, desired)


@pytest.mark.parametrize("joint", range(7))
def test_a_demand_breaking_nothing_near_a_position_limit_passes_unchanged(robot, limits, joint: int) -> None:
    """Near a position limit (inside the braking room, where the far-from-limits test cannot decide) a demand that
    breaks no constraint is the command as it is: no flag, no QP, a change of exactly 0 N m (not the fast path's
    report, which says the state is far from the limits)."""
    optimisation = PosturalOptimisation(limits, DT)
    q = np.array(NOMINAL_CONFIGURATION)
    q[joint] = limits.joint_position_upper[joint] - 0.02   # 20 mrad from its upper limit, at rest
    robot.update(q, np.zeros(7))
    bias = robot.nonlinear_effects.copy()
    desired = bias.copy()
    desired[joint] -= 0.05   # a slight pull away from the limit
    result, _ = shape(optimisation, robot, q, np.zeros(7), desired, bias)
    assert result.flags == LimitFlag.NONE and not result.fast_path
    assert not result.solved_qp and result.iterations == 0 and optimisation.qp_count == 0
    assert result.torque_change == 0.0 and not result.relaxed and not result.guard_clipped
    np.testing.assert_array_equal(result.torque, desired)


def test_torque_saturation_is_flagged_torque(robot, limits) -> None:
    optimisation = PosturalOptimisation(limits, DT)
    qd = np.zeros(7)
    qd[4] = -2.5  # joint 5 moving the other way, so that 12 N m cannot bring it to its velocity limit
    robot.update(NOMINAL_CONFIGURATION, qd)
    desired = robot.nonlinear_effects.copy()
    desired[4] = 30.0  # joint 5's limit is 12 N m
    result, bias = shape(optimisation, robot, NOMINAL_CONFIGURATION, qd, desired, None)
    assert result.flags == LimitFlag.TORQUE
    assert result.solved_qp and result.iterations >= 1   # the QP ran: its solver's iterations, counted up
    assert result.torque[4] == pytest.approx(12.0)
    assert result.torque_change > 0.0
    assert_inside_box(result, None, limits)


def test_torque_rate_is_flagged_and_respected(robot, limits) -> None:
    optimisation = PosturalOptimisation(limits, DT)
    robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    previous = robot.nonlinear_effects.copy()
    desired = previous.copy()
    desired[1] += 5.0
    result, _ = shape(optimisation, robot, NOMINAL_CONFIGURATION, np.zeros(7), desired, previous)
    assert result.flags == LimitFlag.TORQUE_RATE
    assert result.torque[1] == pytest.approx(previous[1] + 1.0)
    assert_inside_box(result, previous, limits)


def test_joint_velocity_limit_brakes(robot, limits) -> None:
    optimisation = PosturalOptimisation(limits, DT)
    qd = np.zeros(7)
    qd[0] = 2.15  # joint 1 close to its 2.175 rad/s limit
    robot.update(NOMINAL_CONFIGURATION, qd)
    bias = robot.nonlinear_effects + robot.joint_damping * qd
    desired = bias + robot.mass_matrix @ np.array([5.0, 0, 0, 0, 0, 0, 0])  # keep accelerating joint 1
    result, bias = shape(optimisation, robot, NOMINAL_CONFIGURATION, qd, desired, None)
    assert result.flags & LimitFlag.JOINT_VELOCITY
    assert not result.flags & LimitFlag.JOINT_POSITION
    ahead, _ = predicted_velocity(optimisation, robot, result.torque, bias)
    assert ahead[0] <= 2.175 + PREDICTION_TOLERANCE
    assert ahead[0] == pytest.approx(2.175, abs=1e-4)  # active: the constraint, not more


def test_joint_position_limit_brakes_in_time(robot, limits) -> None:
    optimisation = PosturalOptimisation(limits, DT)
    room = 0.05  # rad from joint 4's upper limit
    q = NOMINAL_CONFIGURATION.copy()
    q[3] = limits.joint_position_upper[3] - room
    a, lag = optimisation.braking_deceleration[3], optimisation.horizon + BRAKING_TORQUE_RAMP
    braking_speed = a * (np.sqrt(lag ** 2 + 2 * room / a) - lag)
    qd = np.zeros(7)
    qd[3] = braking_speed + 0.02  # toward the limit, a little faster than the braking curve allows
    robot.update(q, qd)
    bias = robot.nonlinear_effects + robot.joint_damping * qd
    result, bias = shape(optimisation, robot, q, qd, bias, None)  # tau_d: coast on
    assert result.flags & LimitFlag.JOINT_POSITION
    assert not result.relaxed
    next_velocity = qd + DT * robot.mass_matrix_inverse @ (result.torque - bias)
    # Back on the braking curve: from the next velocity v it stops within the room left, braking at a after the lag.
    assert next_velocity[3] == pytest.approx(optimisation.braking_velocity(q)[1][3], abs=1e-6)
    assert next_velocity[3] * lag + next_velocity[3] ** 2 / (2 * a) <= room + 1e-6


def _tcp_at_1_65_m_s(robot, limits) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A configuration moving at 1.65 m/s at the TCP, near its 1.7 m/s limit (robot updated to it), and the torque
    that pushes on along that direction with 20 N at the TCP: (q, qd, pushing)."""
    q = np.array([-0.994, -0.313, -1.997, -1.823, -2.153, 1.711, -2.071])
    direction = np.array([-0.125, -0.787, 0.604])
    robot.update(q, np.zeros(7))
    weights = np.diag(limits.joint_velocity_array)
    joint_direction = weights @ np.linalg.pinv(robot.tcp_jacobian[:3] @ weights) @ direction
    qd = joint_direction * 1.65 / np.linalg.norm(robot.tcp_jacobian[:3] @ joint_direction)
    robot.update(q, qd)
    pushing = robot.nonlinear_effects + robot.joint_damping * qd + robot.tcp_jacobian[:3].T @ (20.0 * direction)
    return q, qd, pushing


def test_tcp_speed_limit(robot, limits) -> None:
    optimisation = PosturalOptimisation(limits, DT)
    q, qd, pushing = _tcp_at_1_65_m_s(robot, limits)
    # A configuration and direction where 1.65 m/s at the TCP needs less than half of every joint speed limit.
    assert np.all(np.abs(qd) < 0.5 * limits.joint_velocity_array)
    result, bias = shape(optimisation, robot, q, qd, pushing, None)
    assert result.flags == LimitFlag.TCP_SPEED
    _, tcp_ahead = predicted_velocity(optimisation, robot, result.torque, bias)
    assert np.linalg.norm(tcp_ahead) <= 1.7 * (1 + TCP_RELATIVE_TOLERANCE)
    assert np.linalg.norm(tcp_ahead) >= 1.7 * (1 - 2e-3)  # braked to the limit, not far below it


def test_the_tcp_speed_cut_is_flagged_whenever_it_shapes_the_command_with_other_limits(robot, limits) -> None:
    """The TCP-speed case above with one joint's demand also 20 N m past its torque limit, each joint either way, so
    that a joint limit shapes the command too: TCP_SPEED is flagged exactly when the command is braked onto the TCP
    limit (its cut active at the solution), beside the joint limit's flag, as when it is the only one shaping it."""
    optimisation = PosturalOptimisation(limits, DT)
    q, qd, pushing = _tcp_at_1_65_m_s(robot, limits)
    both = 0
    for joint in range(7):
        for sign in (1.0, -1.0):
            demand = pushing.copy()
            demand[joint] = sign * (limits.torque[joint] + 20.0)
            result, bias = shape(optimisation, robot, q, qd, demand, None)
            assert result.flags & ~LimitFlag.TCP_SPEED, (joint, sign)   # a joint limit shaped it as well
            _, tcp_ahead = predicted_velocity(optimisation, robot, result.torque, bias)
            on_the_limit = np.linalg.norm(tcp_ahead) >= 1.7 * (1 - 2e-3)
            assert (LimitFlag.TCP_SPEED in result.flags) == on_the_limit, (joint, sign, np.linalg.norm(tcp_ahead))
            both += on_the_limit
    assert both >= 7


def test_joint_beyond_its_limit_relaxes_without_exception(robot, limits) -> None:
    optimisation = PosturalOptimisation(limits, DT)
    q = NOMINAL_CONFIGURATION.copy()
    q[0] = limits.joint_position_upper[0] + 0.05
    qd = np.zeros(7)
    qd[0] = 2.5  # beyond the velocity limit too, moving further out
    robot.update(q, qd)
    previous = robot.nonlinear_effects.copy()
    result, _ = shape(optimisation, robot, q, qd, previous + 50.0, previous)
    assert result.solved_qp
    assert result.relaxed
    assert result.flags & LimitFlag.JOINT_POSITION
    assert_inside_box(result, previous, limits)
    # It still brakes as hard as the torque-rate box allows.
    assert result.torque[0] == pytest.approx(previous[0] - 1.0)


def test_previous_torque_beyond_the_torque_limit_torque_wins(robot, limits) -> None:
    optimisation = PosturalOptimisation(limits, DT)
    previous = np.zeros(7)
    previous[5] = 20.0  # an outside command (not ours) above joint 6's 12 N m
    result, _ = shape(optimisation, robot, NOMINAL_CONFIGURATION, np.zeros(7), previous, previous)
    assert abs(result.torque[5]) <= 12.0
    assert result.flags & LimitFlag.TORQUE


def test_random_states_and_huge_demands(robot, limits) -> None:
    """Thousands of random states (joints anywhere in range incl. right at the limits, velocities up to 110 % of
    the limits), random previous commands inside the limits and huge random torque demands."""
    rng = np.random.default_rng(11)
    lower, upper = limits.lower_array, limits.upper_array
    v_max = limits.joint_velocity_array
    counts = {"fast": 0, "qp": 0, "relaxed": 0, "feasible qp": 0, "tcp": 0}
    for dt in (0.001, 0.004, 0.02):
        optimisation = PosturalOptimisation(limits, dt)
        for _ in range(800):
            near = rng.random(7) < 0.3
            edge = np.where(rng.random(7) < 0.5, lower + rng.uniform(0, 0.1, 7), upper - rng.uniform(0, 0.1, 7))
            q = np.where(near, edge, rng.uniform(lower, upper))
            qd = rng.uniform(-1.1, 1.1, 7) * v_max * rng.choice([0.1, 0.5, 1.0])
            robot.update(q, qd)
            kind = rng.random()
            if kind < 0.5:  # the last command was near what the arm needs now
                previous = np.clip(robot.nonlinear_effects + rng.normal(size=7), -limits.torque_array,
                                   limits.torque_array)
            elif kind < 0.8:  # anything inside the limits
                previous = rng.uniform(-1, 1, 7) * limits.torque_array
            else:  # the first command
                previous = None
            scale = rng.choice([0.3, 3.0, 30.0, 1000.0])
            desired = robot.nonlinear_effects + rng.normal(size=7) * scale
            result, bias = shape(optimisation, robot, q, qd, desired, previous)

            assert np.all(np.isfinite(result.torque))
            assert_inside_box(result, previous, limits, dt)
            # Flags exactly when shaped.
            if result.flags == LimitFlag.NONE:
                np.testing.assert_array_equal(result.torque, desired)
                counts["fast"] += 1
            else:
                assert result.solved_qp
                assert result.torque_change == pytest.approx(np.linalg.norm(result.torque - desired))
                counts["qp"] += 1
            if result.relaxed:
                counts["relaxed"] += 1
                continue
            counts["feasible qp"] += result.solved_qp
            # Feasible: the velocity on the horizon respects the velocity limits, the next sample's velocity the
            # braking curve of the position limits, and the TCP speed its limit.
            ahead, tcp_ahead = predicted_velocity(optimisation, robot, result.torque, bias)
            v_max = limits.joint_velocity_array
            assert np.all(np.abs(ahead) <= v_max + PREDICTION_TOLERANCE)
            next_velocity = robot.qd + dt * robot.mass_matrix_inverse @ (result.torque - bias)
            brake_lo, brake_hi = optimisation.braking_velocity(robot.q)
            inside = (robot.q >= lower) & (robot.q <= upper)
            assert np.all(next_velocity[inside] <= brake_hi[inside] + PREDICTION_TOLERANCE)
            assert np.all(next_velocity[inside] >= brake_lo[inside] - PREDICTION_TOLERANCE)
            current_tcp = np.linalg.norm(robot.tcp_jacobian[:3] @ robot.qd)
            if current_tcp <= limits.tcp_speed:
                assert np.linalg.norm(tcp_ahead) <= limits.tcp_speed * (1 + TCP_RELATIVE_TOLERANCE)
                counts["tcp"] += 1
            # The next sample stays inside the position limits if this one is.
            next_q = robot.q + dt * (robot.qd + dt * robot.mass_matrix_inverse @ (result.torque - bias))
            assert np.all(next_q[inside] <= upper[inside] + 1e-6)
            assert np.all(next_q[inside] >= lower[inside] - 1e-6)
    # The sample exercised both paths and the infeasible case.
    assert counts["fast"] > 100 and counts["feasible qp"] > 300 and counts["relaxed"] > 10, counts


def test_float_shortcut_agrees_with_the_flag_computation(robot, limits) -> None:
    """The shortcut on floats that passes tau_d unshaped near the position limits (``_satisfies_every_limit``)
    gives exactly what the flag computation with numpy gives, on random states near and at the limits."""
    rng = np.random.default_rng(31)
    fast = PosturalOptimisation(limits, DT)
    reference = PosturalOptimisation(limits, DT)
    reference._satisfies_every_limit = lambda *arguments: False  # always the numpy path
    lower, upper, v_max = limits.lower_array, limits.upper_array, limits.joint_velocity_array
    unshaped = 0
    for _ in range(400):
        near = rng.random(7) < 0.4
        edge = np.where(rng.random(7) < 0.5, lower + rng.uniform(-0.01, 0.3, 7), upper - rng.uniform(-0.01, 0.3, 7))
        q = np.where(near, edge, rng.uniform(lower + 0.3, upper - 0.3))
        qd = rng.uniform(-0.3, 0.3, 7) * v_max
        robot.update(q, qd)
        desired = robot.nonlinear_effects + rng.normal(scale=0.3, size=7)
        previous = desired + rng.normal(scale=0.3, size=7)
        first, _ = shape(fast, robot, q, qd, desired, previous)
        second, _ = shape(reference, robot, q, qd, desired, previous)
        assert first.flags == second.flags and first.solved_qp == second.solved_qp
        np.testing.assert_allclose(first.torque, second.torque, atol=1e-9)
        unshaped += not first.solved_qp and not first.fast_path
    assert unshaped > 50  # the shortcut was exercised


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_a_joint_past_its_limit_is_pulled_back_at_the_return_speed(robot, limits, side: float) -> None:
    """Past a position limit the joint's bound is the return velocity on the horizon T (module docstring):
    qd + T qdd must reach (q_limit - q) / T, back inside. Written out for joint 4 at rest 2 mrad past its upper
    (lower) limit with tau_d pushing it further out: qdd_4 <= ((q_max - q) / T - qd) / T < 0 (>= for the lower
    limit), with qdd = M^-1 (tau - C qd - g - D qd) from Pinocchio calls of the test."""
    import pinocchio as pin

    optimisation = PosturalOptimisation(limits, DT)
    q = NOMINAL_CONFIGURATION.copy()
    limit = limits.joint_position_upper[3] if side > 0 else limits.joint_position_lower[3]
    q[3] = limit + side * 0.002
    qd = np.zeros(7)
    robot.update(q, qd)
    outward = np.zeros(7)
    outward[3] = side * 2.0
    result, _ = shape(optimisation, robot, q, qd, robot.nonlinear_effects + outward, None)
    assert result.solved_qp and not result.relaxed
    assert result.flags & LimitFlag.JOINT_POSITION
    model = robot.model
    data = model.createData()
    mass = pin.crba(model, data, q)
    mass = np.triu(mass) + np.triu(mass, 1).T
    bias = pin.rnea(model, data, q, qd, np.zeros(model.nv)) + robot.joint_damping * qd
    acceleration = np.linalg.solve(mass, result.torque - bias)
    horizon = optimisation.horizon
    bound = ((limit - q[3]) / horizon - qd[3]) / horizon   # -0.8 rad/s^2 (upper) or +0.8 (lower) for T = 0.05 s
    assert side * bound < 0.0
    assert side * acceleration[3] <= side * bound + PREDICTION_TOLERANCE / horizon, (acceleration[3], bound)
