"""The postural optimisation's hard box and its last guard, each against the test's own recomputation
(postural_optimisation.py's docstring): the torque box is the torque limits intersected with one rate step from
the last command (the torque limit winning when the last command was past it by more than a step); a solver that
gives up leaves tau_d clipped into that box, counted and flagged; ``shape_rejected`` (the replica's path after its
own fast-path tests) answers as ``shape`` does."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.errors import FicInputError
from fic_core.limits import LimitFlag, PandaLimits
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.postural_optimisation import PosturalOptimisation
from fic_core.robot_model import RobotModel

DT = 0.001


def written_out_box(limits: PandaLimits, previous, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Joint by joint: [max(-tau_max, prev - rate dt), min(tau_max, prev + rate dt)]; a previous command past its
    torque limit by more than a step gives the one-point box at that limit."""
    lower, upper = [], []
    for joint in range(7):
        torque_max = limits.torque[joint]
        if previous is None:
            lower.append(-torque_max)
            upper.append(torque_max)
            continue
        step = limits.torque_rate * dt
        low = max(-torque_max, previous[joint] - step)
        high = min(torque_max, previous[joint] + step)
        if low > high:
            low = high = min(max(previous[joint], -torque_max), torque_max)
        lower.append(low)
        upper.append(high)
    return np.array(lower), np.array(upper)


def dynamics(robot: RobotModel, q, qd):
    state = robot.update(q, qd)
    bias = state.nonlinear_effects + robot.joint_damping * state.qd
    return state, bias, state.mass_matrix_inverse.copy(), state.tcp_jacobian[:3].copy()


@settings(max_examples=60, deadline=None, derandomize=True)
@given(previous=st.one_of(st.none(), st.lists(st.floats(-1.3, 1.3), min_size=7, max_size=7)),
       dt=st.sampled_from([0.001, 0.002, 0.01]))
def test_the_torque_box_is_the_torque_limits_within_one_rate_step_of_the_last_command(limits: PandaLimits,
                                                                                       previous, dt: float) -> None:
    """Previous commands drawn from 1.3 times the limits (on both sides, past them by more or less than a step)."""
    optimisation = PosturalOptimisation(limits, dt)
    previous = None if previous is None else np.array(previous) * limits.torque_array
    lower, upper = optimisation.torque_box(previous)
    expected_lower, expected_upper = written_out_box(limits, previous, dt)
    np.testing.assert_allclose(lower, expected_lower, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(upper, expected_upper, rtol=0.0, atol=1e-12)
    assert np.all(lower <= upper)
    assert np.all(np.abs(lower) <= limits.torque_array) and np.all(np.abs(upper) <= limits.torque_array)


def test_a_solver_that_gives_up_leaves_tau_d_clipped_into_the_box(robot: RobotModel, limits: PandaLimits) -> None:
    """With an iteration limit of one the QP solver stops short of an answer: the command is then tau_d clipped into
    the hard box, joint by joint, the clip counted in ``guard_clips`` and the limits tau_d broke flagged. With the
    default limit the same demands are answered by the QP, inside the box, without the guard."""
    state, bias, minv, jacobian = dynamics(robot, NOMINAL_CONFIGURATION, np.zeros(7))
    previous = state.nonlinear_effects.copy()
    cases = (
        (previous + np.array([5.0, -5.0, 5.0, -5.0, 3.0, -3.0, 3.0]), previous, LimitFlag.TORQUE_RATE),
        (previous + np.array([200.0, 200.0, 200.0, 200.0, 0.0, 0.0, 0.0]), None, LimitFlag.TORQUE),
    )
    for count, (desired, before, broken) in enumerate(cases, start=1):
        gives_up = PosturalOptimisation(limits, DT, iteration_limit=1)
        result = gives_up.shape(desired, before, state.q, state.qd, bias, minv, jacobian)
        lower, upper = written_out_box(limits, before, DT)
        np.testing.assert_allclose(result.torque, np.clip(desired, lower, upper), rtol=0.0, atol=1e-12)
        assert result.guard_clipped and result.solved_qp
        assert broken in result.flags
        assert (gives_up.qp_count, gives_up.guard_clips) == (1, 1)
        assert result.torque_change == np.linalg.norm(result.torque - desired)

        solver = PosturalOptimisation(limits, DT)
        answered = solver.shape(desired, before, state.q, state.qd, bias, minv, jacobian)
        assert not answered.guard_clipped and solver.guard_clips == 0 and solver.qp_count == 1
        assert np.all(answered.torque >= lower - 1e-9) and np.all(answered.torque <= upper + 1e-9), count


@settings(max_examples=40, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**31 - 1), near=st.booleans(), first=st.booleans())
def test_the_replicas_path_after_its_fast_path_answers_as_shape(robot: RobotModel, limits: PandaLimits, seed: int,
                                                                  near: bool, first: bool) -> None:
    """``shape_rejected`` (what the replica calls once its fast-path tests said no) gives the torque, the flags, the
    change and the solver's report that ``shape`` gives, on random states (some with a joint near a position
    limit) and demands that break a limit."""
    rng = np.random.default_rng(seed)
    q = np.array(NOMINAL_CONFIGURATION) + rng.normal(scale=0.2, size=7)
    if near:
        joint = int(rng.integers(7))
        q[joint] = limits.joint_position_upper[joint] - rng.uniform(0.0, 0.05)
    q = np.clip(q, limits.lower_array + 1e-3, limits.upper_array - 1e-3)
    qd = rng.normal(scale=0.5, size=7)
    state, bias, minv, jacobian = dynamics(robot, q, qd)
    previous = None if first else state.nonlinear_effects + rng.normal(scale=2.0, size=7)
    desired = state.nonlinear_effects + rng.normal(scale=30.0, size=7)
    shaped = PosturalOptimisation(limits, DT).shape(desired, previous, state.q, state.qd, bias, minv, jacobian)
    torque, flags, change, solved_qp, relaxed, guard = PosturalOptimisation(limits, DT).shape_rejected(
        desired, desired.tolist(), None if previous is None else previous.tolist(), state.q.tolist(), state.qd,
        state.qd.tolist(), bias, minv, jacobian)
    np.testing.assert_array_equal(torque, shaped.torque)
    assert LimitFlag(flags) == shaped.flags
    assert (change, solved_qp, relaxed, guard) == (shaped.torque_change, shaped.solved_qp, shaped.relaxed,
                                                   shaped.guard_clipped)


def test_the_tcp_cone_is_cut_along_the_demands_prediction_at_most_tcp_cuts_times(robot: RobotModel,
                                                                                  limits: PandaLimits) -> None:
    """The TCP-speed cone |v_T| <= 1.7 m/s (v_T the TCP velocity T ahead) is met by linear cuts: the first along
    tau_d's own prediction, 0.1 % inside the limit; more, each along the last answer's prediction, while the
    answer is outside the cone and fewer than ``tcp_cuts`` are placed. The 1.65 m/s state of
    test_postural_optimisation, pushed on and sideways: one cut leaves an answer 1.7 % outside the cone, two bring
    it inside, and the answer is on the first cut whenever that is the only one."""
    from test_postural_optimisation import _tcp_at_1_65_m_s

    q, qd, pushing = _tcp_at_1_65_m_s(robot, limits)
    state, bias, minv, jacobian = dynamics(robot, q, qd)
    sideways = jacobian.T @ (20.0 * np.cross([0.0, 0.0, 1.0], jacobian @ qd))
    rng = np.random.default_rng(0)
    extras = [rng.normal(scale=5.0, size=7) for _ in range(3)]
    horizon = PosturalOptimisation(limits, DT).horizon
    outside_after_one = 0
    for extra in extras:
        desired = pushing + sideways + extra
        first_direction = jacobian @ (qd + horizon * minv @ (desired - bias))
        assert np.linalg.norm(first_direction) > 1.7                       # tau_d breaks the TCP limit
        first_direction /= np.linalg.norm(first_direction)
        speeds = {}
        for cuts in (1, 2, 8):
            result = PosturalOptimisation(limits, DT, tcp_cuts=cuts).shape(desired, None, q, qd, bias, minv,
                                                                            jacobian)
            ahead = jacobian @ (qd + horizon * minv @ (result.torque - bias))
            assert LimitFlag.TCP_SPEED in result.flags
            assert first_direction @ ahead <= 1.7 * (1.0 - 1e-3) + 1e-9   # every answer meets the first cut
            if cuts == 1:
                assert first_direction @ ahead == pytest.approx(1.7 * (1.0 - 1e-3), rel=1e-9)
            speeds[cuts] = np.linalg.norm(ahead)
        assert speeds[2] <= 1.7 * (1.0 + 1e-6) and speeds[8] <= 1.7 * (1.0 + 1e-6)
        outside_after_one += speeds[1] > 1.7 * 1.01
    assert outside_after_one == 1
    with pytest.raises(FicInputError, match="tcp_cuts"):
        PosturalOptimisation(limits, DT, tcp_cuts=0)
