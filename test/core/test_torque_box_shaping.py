"""The postural optimisation's hard box in action (postural_optimisation.py's docstring): near a position limit,
where its fast path steps aside, a demand inside the torque limits intersected with one rate step of the last
command passes unchanged and unflagged, whatever side of the limits the last command sat on; one outside the box
is clipped onto it, flagged with the limit whose edge it sits on (TORQUE at +-tau_max, TORQUE_RATE one step from
the last command). An arm so heavy (M^-1 = 1e-4 I, no bias, no TCP motion) that no joint row, braking curve or TCP
limit can bind: only the box shapes, so the QP's answer is the box's clip (test_postural_guard's written-out box)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_postural_guard import written_out_box

from fic_core.limits import LimitFlag, PandaLimits
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.postural_optimisation import PosturalOptimisation

DT = 0.001
HEAVY = 1e-4 * np.eye(7)


def near_a_position_limit(limits: PandaLimits) -> np.ndarray:
    """The nominal pose with joint 4 0.1 rad inside its upper limit (the fast path needs more room than that)."""
    q = np.array(NOMINAL_CONFIGURATION, dtype=float)
    q[3] = limits.upper_array[3] - 0.1
    return q


def shaped(optimisation: PosturalOptimisation, limits: PandaLimits, desired, previous):
    return optimisation.shape(np.array(desired, dtype=float), np.array(previous, dtype=float),
                              near_a_position_limit(limits), np.zeros(7), np.zeros(7), HEAVY, np.zeros((3, 7)))


# A last command anywhere in the limits, often within a step of one (the box then ends on the torque limit), or
# past one (a command stated from outside): by less than a step (the box from the limit to a step back from it)
# or by more (the box is the one point at that limit).
inside_fractions = st.lists(st.one_of(st.floats(-1.0, 1.0), st.sampled_from([-1.0, 1.0, -0.999, 0.999, 0.0])),
                            min_size=7, max_size=7)
any_fractions = st.lists(st.one_of(st.floats(-1.3, 1.3),
                                   st.sampled_from([-1.0, 1.0, -0.999, 0.999, 0.0, -1.005, 1.005, -1.2, 1.2])),
                         min_size=7, max_size=7)


@settings(max_examples=80, deadline=None, derandomize=True)
@given(fractions=inside_fractions, offsets=st.lists(st.floats(-1.0, 1.0), min_size=7, max_size=7))
def test_a_demand_inside_the_box_passes_unchanged(limits: PandaLimits, fractions, offsets) -> None:
    """A last command inside the limits: the box is within one rate step of it, so nothing in it breaks a limit."""
    optimisation = PosturalOptimisation(limits, DT)
    previous = np.array(fractions) * limits.torque_array
    lower, upper = written_out_box(limits, previous, DT)
    desired = lower + (np.array(offsets) + 1.0) / 2.0 * (upper - lower)   # anywhere in it, its edges included
    result = shaped(optimisation, limits, desired, previous)
    assert not result.fast_path   # the joint near its limit sends the demand past the fast path's test
    np.testing.assert_array_equal(result.torque, desired)
    assert (result.flags, result.solved_qp, result.torque_change) == (LimitFlag.NONE, False, 0.0)


@settings(max_examples=80, deadline=None, derandomize=True)
@given(fractions=any_fractions, pushes=st.lists(st.sampled_from([-3.0, -1.5, 0.0, 1.5, 3.0]), min_size=7,
                                                     max_size=7))
def test_a_demand_outside_the_box_is_clipped_onto_it_and_flagged_by_the_edge(limits: PandaLimits, fractions,
                                                                             pushes) -> None:
    optimisation = PosturalOptimisation(limits, DT)
    step = limits.torque_rate * DT
    previous = np.array(fractions) * limits.torque_array
    desired = previous + np.array(pushes) * step
    lower, upper = written_out_box(limits, previous, DT)
    expected = np.clip(desired, lower, upper)
    result = shaped(optimisation, limits, desired, previous)
    np.testing.assert_allclose(result.torque, expected, rtol=0.0, atol=1e-9)
    clipped = np.abs(expected - desired) > 0.0
    at_torque = clipped & (np.abs(expected) >= limits.torque_array - 1e-9)
    at_rate = clipped & (np.abs(expected - previous) >= step - 1e-9)
    flags = (LimitFlag.TORQUE if at_torque.any() else LimitFlag.NONE) | (
        LimitFlag.TORQUE_RATE if at_rate.any() else LimitFlag.NONE)
    assert result.flags == flags
    assert result.solved_qp == bool(clipped.any())


@pytest.mark.parametrize("joint", [0, 4])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_half_a_step_inside_either_torque_limit_the_box_reaches_the_limit_and_stops_there(
        limits: PandaLimits, joint: int, sign: float) -> None:
    """Last command half a rate step inside +-tau_max: a demand a whole step further is cut at the limit itself
    (TORQUE), one a quarter step further is taken as asked."""
    optimisation = PosturalOptimisation(limits, DT)
    step = limits.torque_rate * DT
    previous = np.zeros(7)
    previous[joint] = sign * (limits.torque[joint] - 0.5 * step)
    far, near = previous.copy(), previous.copy()
    far[joint] += sign * step
    near[joint] += sign * 0.25 * step
    result = shaped(optimisation, limits, far, previous)
    assert result.torque[joint] == pytest.approx(sign * limits.torque[joint], abs=1e-9)
    assert result.flags == LimitFlag.TORQUE
    result = shaped(optimisation, limits, near, previous)
    np.testing.assert_array_equal(result.torque, near)
    assert result.flags == LimitFlag.NONE


@settings(max_examples=80, deadline=None, derandomize=True)
@given(fractions=any_fractions, pushes=st.lists(st.sampled_from([-3.0, -1.5, -1.0, 0.0, 1.0, 1.5, 3.0]), min_size=7,
                                                max_size=7))
def test_when_the_solver_gives_up_the_flags_are_what_tau_d_breaks_and_where_the_clip_leaves_it(
        limits: PandaLimits, fractions, pushes) -> None:
    """A solver that gives up (``iteration_limit`` 1) leaves tau_d clipped into the box by the last guard: the
    flags are then the limits tau_d breaks (|tau_d| > tau_max: TORQUE; |tau_d - tau_prev| > one rate step:
    TORQUE_RATE) and those whose edge the clip put a joint on; demands at exactly one step from the last command
    or exactly at a torque limit break nothing."""
    gives_up = PosturalOptimisation(limits, DT, iteration_limit=1)
    step = gives_up.rate_step
    previous = np.array(fractions) * limits.torque_array
    desired = previous + np.array(pushes) * step
    torque_max = limits.torque_array
    breaks = (LimitFlag.TORQUE if np.any(np.abs(desired) > torque_max) else LimitFlag.NONE) | (
        LimitFlag.TORQUE_RATE if np.any(np.abs(desired - previous) > step) else LimitFlag.NONE)
    result = shaped(gives_up, limits, desired, previous)
    lower, upper = written_out_box(limits, previous, DT)
    clipped = np.clip(desired, lower, upper)
    np.testing.assert_allclose(result.torque, clipped, rtol=0.0, atol=1e-9)
    if not result.guard_clipped:
        return   # solved within the one iteration
    moved = np.abs(clipped - desired) > 1e-9
    edges = (LimitFlag.TORQUE if np.any(moved & (np.abs(clipped) >= torque_max - 1e-9)) else LimitFlag.NONE) | (
        LimitFlag.TORQUE_RATE if np.any(moved & (np.abs(clipped - previous) >= step - 1e-9)) else LimitFlag.NONE)
    assert result.flags == breaks | (edges or LimitFlag.TORQUE)


@pytest.mark.parametrize("broken", [LimitFlag.TORQUE, LimitFlag.TORQUE_RATE])
def test_a_demand_exactly_one_step_away_or_exactly_at_a_limit_adds_no_flag_to_a_given_up_solve(
        limits: PandaLimits, broken: LimitFlag) -> None:
    """Joint 1 breaks one limit alone (its torque limit within a rate step, or a rate step within its torque
    limit); joint 2 asks exactly one rate step (10 -> 11 N m, exact in floats), joint 3 exactly its torque limit,
    the others what they had: a solver that gives up reports joint 1's limit alone."""
    gives_up = PosturalOptimisation(limits, DT, iteration_limit=1)
    step = gives_up.rate_step
    assert step == 1.0
    previous = 0.3 * limits.torque_array
    previous[1], previous[2] = 10.0, limits.torque[2] - 0.5
    desired = previous.copy()
    desired[1], desired[2] = 11.0, limits.torque[2]
    assert desired[1] - previous[1] == step and desired[2] == limits.torque[2]
    if broken == LimitFlag.TORQUE:
        previous[0], desired[0], edge = limits.torque[0] - 0.5, limits.torque[0] + 0.25, limits.torque[0]
    else:
        previous[0], desired[0], edge = 0.0, 2.0, 1.0
    result = shaped(gives_up, limits, desired, previous)
    assert result.guard_clipped and result.solved_qp
    expected = desired.copy()
    expected[0] = edge
    np.testing.assert_allclose(result.torque, expected, rtol=0.0, atol=1e-12)
    assert result.flags == broken
