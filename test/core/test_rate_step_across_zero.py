"""The torque-rate limit is on the change from the last command, |tau_d - tau_prev| <= rate x dt, whatever the two
signs (postural_optimisation.py's docstring). Far from every limit, where the fast path decides, a demand crossing
zero by more than a step from a last command of the other sign (each less than a step from zero) is no unshaped
command: it is clipped to one step from the last command and flagged TORQUE_RATE; one crossing zero within a step
passes unchanged. limits.violation_flags judges the torques sent the same way. The heavy toy arm of
test_torque_box_shaping (M^-1 = 1e-4 I, no bias, no TCP motion): only the box can bind."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.limits import LimitFlag, PandaLimits, limit_violations, violation_flags
from fic_core.postural_optimisation import PosturalOptimisation

DT = 0.001
HEAVY = 1e-4 * np.eye(7)


def _shaped(optimisation: PosturalOptimisation, desired: np.ndarray, previous: np.ndarray):
    limits = optimisation.limits
    middle = 0.5 * (limits.lower_array + limits.upper_array)     # every joint far from its limits
    return optimisation.shape(desired, previous, middle, np.zeros(7), np.zeros(7), HEAVY, np.zeros((3, 7)))


@pytest.mark.parametrize("joint", [0, 4, 6])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_demand_crossing_zero_is_held_to_one_step_from_the_last_command(limits: PandaLimits, joint: int,
                                                                          sign: float) -> None:
    optimisation = PosturalOptimisation(limits, DT)
    step = optimisation.rate_step
    previous = np.zeros(7)
    previous[joint] = sign * 0.75 * step
    within, beyond = previous.copy(), previous.copy()
    within[joint] = -sign * 0.125 * step        # 0.875 of a step from the last command
    beyond[joint] = -sign * 0.5 * step          # 1.25 steps
    kept = _shaped(optimisation, within, previous)
    np.testing.assert_array_equal(kept.torque, within)
    assert kept.flags == LimitFlag.NONE and kept.fast_path
    clipped = _shaped(optimisation, beyond, previous)
    assert clipped.torque[joint] == pytest.approx(previous[joint] - sign * step, abs=1e-9)
    assert clipped.flags == LimitFlag.TORQUE_RATE and not clipped.fast_path


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_the_torques_sent_are_judged_on_their_change_across_zero(limits: PandaLimits, sign: float) -> None:
    step = limits.torque_rate * DT
    q = 0.5 * (limits.lower_array + limits.upper_array)
    previous = np.zeros(7)
    previous[2] = sign * 0.75 * step
    for after, expected in ((-0.125, LimitFlag.NONE), (-0.5, LimitFlag.TORQUE_RATE)):
        torque = previous.copy()
        torque[2] = sign * after * step
        assert violation_flags(previous, torque, q, np.zeros(7), 0.0, DT, limits) == expected
        assert limit_violations(previous, torque, q, np.zeros(7), 0.0, DT, limits) == expected
