"""The TCP velocity T ahead that the postural optimisation checks against 1.7 m/s is predicted with the bias the
torque works against (``shape``'s docstring: M qdd = tau - bias, bias = C qd + g + D qd): a bias that helps the
motion pushes a demand's prediction past the limit, one that resists it keeps it inside, on ``shape`` and on the
replica's path after its own fast-path tests (``shape_rejected``) alike. A toy arm makes the figures exact: M^-1 = I,
joint 1 alone moving the TCP along x at 1 m/s per rad/s, T = 1/16 s, so v_T = qd_1 + (tau_1 - bias_1) / 16."""
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
DEMAND = 24.0   # [N m] on joint 1: v_T = 1.5 m/s with no bias


@pytest.mark.parametrize("speed_1, bias_1", [(0.0, -8.0), (0.0, 8.0), (0.0, -3.2), (0.0, 3.2), (0.0, 0.0),
                                             (0.25, -4.8), (0.25, 4.8)])
def test_the_prediction_is_the_demand_minus_the_bias(limits: PandaLimits, speed_1: float, bias_1: float) -> None:
    """v_T = (24 - bias_1) / 16: 2.0 m/s with -8 N m (flagged, shaped onto the cone), 1.0 m/s with +8 N m, exactly
    1.7 m/s with -3.2 N m (inside: the limit is inclusive), 1.3 m/s with +3.2 N m, 1.5 m/s with none; from
    qd_1 = 0.25 rad/s, 2.05 m/s with -4.8 N m, 1.45 m/s with +4.8 N m (all joints inside their velocity bound). A first
    command (no last one, so no rate step)."""
    zeros = np.zeros(7)
    desired, bias, qd = zeros.copy(), zeros.copy(), zeros.copy()
    desired[0], bias[0], qd[0] = DEMAND, bias_1, speed_1
    predicted = speed_1 + (DEMAND - bias_1) * HORIZON
    breaks = predicted > limits.tcp_speed
    optimisation = PosturalOptimisation(limits, 0.001, velocity_horizon=HORIZON)
    torque, flags, change, solved_qp, _, guard = optimisation.shape_rejected(
        desired, desired.tolist(), None, Q.tolist(), qd, qd.tolist(), bias, np.eye(7), JACOBIAN)
    shaped = optimisation.shape(desired, None, Q, qd, bias, np.eye(7), JACOBIAN)
    for answer, answer_flags, answer_qp in ((torque, LimitFlag(flags), solved_qp),
                                            (shaped.torque, shaped.flags, shaped.solved_qp)):
        if breaks:
            assert answer_flags == LimitFlag.TCP_SPEED and answer_qp
            # The answer's own prediction is on the cut, 0.1 % inside the limit (at most the limit).
            assert speed_1 + (answer[0] - bias_1) * HORIZON <= limits.tcp_speed
            assert speed_1 + (answer[0] - bias_1) * HORIZON == pytest.approx(limits.tcp_speed, rel=2e-3)
        else:
            assert answer_flags == LimitFlag.NONE and not answer_qp
            np.testing.assert_array_equal(answer, desired)
    assert not guard and (change > 0.0) == breaks
