"""The postural optimisation's bounds on qdd (postural_optimisation.py's docstring: the tightest of the velocity
limit on the horizon, the braking curve and the range on the next sample) for joints moving FASTER than their
velocity limit, anywhere inside the range, near their limits and far from them: a joint far from its limits that
is too fast must still see the braking curve, not the velocity limit alone. Against test_oracles' written-out
bounds (where the two sides contradict, a joint too fast too close to its limit, the position side is kept)."""
from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from test_oracles import written_out_acceleration_bounds

from fic_core.limits import PandaLimits
from fic_core.postural_optimisation import PosturalOptimisation


def expected_bounds(limits: PandaLimits, q, qd, dt: float, horizon: float):
    low, high = written_out_acceleration_bounds(limits, q, qd, dt, horizon)
    high_by_position = high < (limits.joint_velocity_array - qd) / horizon
    conflict = low > high
    low = np.where(conflict & high_by_position, high, low)
    high = np.where(conflict & ~high_by_position, low, high)
    return low, high, bool(np.any(conflict))


@settings(max_examples=150, deadline=None, derandomize=True)
@given(fractions=st.lists(st.floats(0.001, 0.999), min_size=7, max_size=7),
       speeds=st.lists(st.one_of(st.floats(1.0, 1.6), st.floats(-1.6, -1.0), st.sampled_from([1.0, -1.0])),
                       min_size=7, max_size=7),
       dt=st.sampled_from([0.001, 0.004, 0.02]))
def test_a_joint_at_or_past_its_velocity_limit_gets_the_written_out_bounds_anywhere_in_its_range(
        limits: PandaLimits, fractions: list[float], speeds: list[float], dt: float) -> None:
    optimisation = PosturalOptimisation(limits, dt)
    q = limits.lower_array + np.array(fractions) * (limits.upper_array - limits.lower_array)
    qd = np.array(speeds) * limits.joint_velocity_array
    low, high, _, _, reconciled = optimisation.acceleration_bounds(q, qd)
    expected_low, expected_high, conflict = expected_bounds(limits, q, qd, dt, optimisation.horizon)
    np.testing.assert_allclose(low, expected_low, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(high, expected_high, rtol=1e-12, atol=1e-9)
    assert reconciled == conflict


def test_a_fast_joint_far_from_its_limits_is_braked_by_the_next_samples_velocity(limits: PandaLimits) -> None:
    """Joint 1 0.6 rad from either limit (farther than the braking distance from v_max) at 1.5 v_max toward it:
    its velocity on the next sample must come back under the braking velocity there, a bound far tighter than the
    velocity limit's (v_max - qd)/T."""
    dt = 0.001
    optimisation = PosturalOptimisation(limits, dt)
    v_max = limits.joint_velocity[0]
    for sign in (1.0, -1.0):
        q = 0.5 * (limits.lower_array + limits.upper_array)
        q[0] = limits.upper_array[0] - 0.6 if sign > 0.0 else limits.lower_array[0] + 0.6
        qd = np.zeros(7)
        qd[0] = sign * 1.5 * v_max
        low, high, _, _, _ = optimisation.acceleration_bounds(q, qd)
        brake_low, brake_high = optimisation.braking_velocity(q)
        if sign > 0.0:
            assert v_max < brake_high[0] < qd[0]
            assert high[0] == (brake_high[0] - qd[0]) / dt < (v_max - qd[0]) / optimisation.horizon
        else:
            assert qd[0] < brake_low[0] < -v_max
            assert low[0] == (brake_low[0] - qd[0]) / dt > (-v_max - qd[0]) / optimisation.horizon
