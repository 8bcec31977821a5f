"""shape()'s fast path takes tau_d "in the box, |qd| within the velocity limits" (ShapedTorque.fast_path): the box
and the limits are closed, so a joint exactly on one of them (torque at tau_max, a step of exactly the rate box from
the last torque, |qd| or the velocity T ahead exactly v_max, the TCP speed T ahead exactly its limit) is inside, and
tau_d passes the fast path unshaped, bit for bit, with no flag; one float past the bound it does not. M^-1 = I and
a horizon of 2^-4 s make the predicted velocity qd + T M^-1 (tau_d - bias) exact."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.limits import LimitFlag, PandaLimits
from fic_core.postural_optimisation import PosturalOptimisation

HORIZON = 0.0625   # [s] a power of two: T x qdd is exact


def _case(limits: PandaLimits, optimisation: PosturalOptimisation, bound: str, joint: int, sign: float,
          past: bool):
    """(tau_d, previous, qd, bias, TCP Jacobian) with one joint exactly on ``bound`` (or one float past it)."""
    desired, previous, qd, bias, jacobian = np.zeros(7), None, np.zeros(7), np.zeros(7), np.zeros((3, 7))
    nudge = (lambda value: np.nextafter(value, np.inf)) if past else (lambda value: value)
    if bound == "torque":
        desired[joint] = sign * nudge(limits.torque_array[joint])
        bias = desired.copy()                                   # no acceleration
    elif bound == "rate":
        step = nudge(optimisation.rate_step)
        previous = np.zeros(7)
        previous[joint] = -sign * step                          # |0 - previous| = the rate box, exactly
    elif bound == "velocity":
        qd[joint] = sign * nudge(limits.joint_velocity_array[joint])   # no acceleration: the same T ahead
    elif bound == "velocity ahead":                             # from rest
        bias[joint] = -sign * nudge(limits.joint_velocity_array[joint]) / HORIZON
    else:                                                       # the TCP moves with the joint, 1 m/s per rad/s
        jacobian[int(joint > 0), joint] = 1.0
        bias[joint] = -sign * nudge(limits.tcp_speed) / HORIZON
    return desired, previous, qd, bias, jacobian


@pytest.mark.parametrize("bound", ["torque", "rate", "velocity", "velocity ahead", "tcp speed"])
@pytest.mark.parametrize("joint, sign", [(0, 1.0), (3, -1.0), (6, 1.0)])
def test_a_joint_exactly_on_a_bound_takes_the_fast_path_and_one_float_past_is_shaped(
        limits: PandaLimits, bound: str, joint: int, sign: float) -> None:
    optimisation = PosturalOptimisation(limits, 0.001, velocity_horizon=HORIZON)
    q = 0.5 * (limits.lower_array + limits.upper_array)        # every joint far from its position limits
    for past in (False, True):
        desired, previous, qd, bias, jacobian = _case(limits, optimisation, bound, joint, sign, past)
        result = optimisation.shape(desired, previous, q, qd, bias, np.eye(7), jacobian)
        if past:
            assert not result.fast_path
        else:
            assert result.fast_path and result.flags == LimitFlag.NONE and not result.solved_qp
            np.testing.assert_array_equal(result.torque, desired)
