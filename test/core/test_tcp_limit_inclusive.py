"""The TCP speed limit is inclusive (docs/CONTROL_LAWS.md, "The limits": |v_TCP| <= 1.7 m/s): a demand whose TCP
velocity T ahead is exactly 1.7 m/s breaks nothing, so the postural optimisation neither flags TCP_SPEED nor cuts
the TCP cone for it, on the replica's path after its own fast-path tests (``shape_rejected``) and on ``shape``
with another joint breaking the rate box. A toy arm makes "exactly" exact: M^-1 = I, no bias, joint 1 alone
moving the TCP along x at 1 m/s per rad/s, T = 1/16 s, so T tau_1 = 1.7 m/s to the last bit for tau_1 = 27.2."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.limits import LimitFlag, PandaLimits
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.postural_optimisation import PosturalOptimisation

HORIZON = 0.0625
JACOBIAN = np.zeros((3, 7))
JACOBIAN[0, 0] = 1.0
Q = np.array(NOMINAL_CONFIGURATION, dtype=float)


def at_the_limit(limits: PandaLimits) -> np.ndarray:
    desired = np.zeros(7)
    desired[0] = limits.tcp_speed / HORIZON
    assert HORIZON * desired[0] == limits.tcp_speed   # exactly on the limit
    return desired


@pytest.mark.parametrize("scale", [1.0, 1.0 + 1e-6])
def test_a_demand_exactly_at_the_tcp_limit_is_not_shaped_one_just_past_it_is(limits: PandaLimits,
                                                                              scale: float) -> None:
    optimisation = PosturalOptimisation(limits, 0.001, velocity_horizon=HORIZON)
    desired = at_the_limit(limits) * scale
    zeros = np.zeros(7)
    torque, flags, change, solved_qp, relaxed, guard = optimisation.shape_rejected(
        desired, desired.tolist(), desired.tolist(), Q.tolist(), zeros, zeros.tolist(), zeros, np.eye(7), JACOBIAN)
    if scale == 1.0:
        assert torque is desired and (flags, change, solved_qp, relaxed, guard) == (0, 0.0, False, False, False)
    else:
        assert flags == LimitFlag.TCP_SPEED and solved_qp and not guard
        assert HORIZON * torque[0] <= limits.tcp_speed


def test_at_the_tcp_limit_a_rate_break_elsewhere_is_shaped_without_cutting_the_cone(limits: PandaLimits) -> None:
    """Joint 2 asks two rate steps: the QP clips it to one and leaves joint 1 exactly where it was asked."""
    optimisation = PosturalOptimisation(limits, 0.001, velocity_horizon=HORIZON)
    previous = at_the_limit(limits)
    desired = previous.copy()
    desired[1] = 2.0 * optimisation.rate_step
    result = optimisation.shape(desired, previous, Q, np.zeros(7), np.zeros(7), np.eye(7), JACOBIAN)
    assert result.flags == LimitFlag.TORQUE_RATE and result.solved_qp
    assert result.torque[0] == pytest.approx(desired[0], abs=1e-9)
    assert result.torque[1] == pytest.approx(optimisation.rate_step, abs=1e-9)
