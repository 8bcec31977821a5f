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


# A last command anywhere in the limits, often within a step of one (the box then ends on the torque limit).
previous_fractions = st.lists(st.one_of(st.floats(-1.0, 1.0), st.sampled_from([-1.0, 1.0, -0.999, 0.999, 0.0])),
                              min_size=7, max_size=7)


@settings(max_examples=80, deadline=None, derandomize=True)
@given(fractions=previous_fractions, offsets=st.lists(st.floats(-1.0, 1.0), min_size=7, max_size=7))
def test_a_demand_inside_the_box_passes_unchanged(limits: PandaLimits, fractions, offsets) -> None:
    optimisation = PosturalOptimisation(limits, DT)
    previous = np.array(fractions) * limits.torque_array
    lower, upper = written_out_box(limits, previous, DT)
    desired = lower + (np.array(offsets) + 1.0) / 2.0 * (upper - lower)   # anywhere in it, its edges included
    result = shaped(optimisation, limits, desired, previous)
    assert not result.fast_path   # the joint near its limit sends the demand past the fast path's test
    np.testing.assert_array_equal(result.torque, desired)
    assert (result.flags, result.solved_qp, result.torque_change) == (LimitFlag.NONE, False, 0.0)


@settings(max_examples=80, deadline=None, derandomize=True)
@given(fractions=previous_fractions, pushes=st.lists(st.sampled_from([-3.0, -1.5, 0.0, 1.5, 3.0]), min_size=7,
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
