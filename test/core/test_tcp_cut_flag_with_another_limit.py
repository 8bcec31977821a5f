"""A TCP cut that shapes the command is named by TCP_SPEED even when another limit is active at the QP's solution
too (docs/CONTROL_LAWS.md, "The limits": the flags name every limit that shaped tau). A toy arm makes the oracle
plain: M^-1 = I, no bias, joint 1 alone moving the TCP along x at 1 m/s per rad/s, T = 1/16 s; joint 1 asks a
torque within its torque and rate limits whose TCP speed T ahead is past 1.7 m/s, so only the TCP limit can have
lowered it, while joint 2 asks two rate steps and is clipped to one."""
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


@pytest.mark.parametrize("past", [0.25, 0.5])
def test_a_tcp_cut_beside_a_rate_clip_is_flagged_with_it(limits: PandaLimits, past: float) -> None:
    optimisation = PosturalOptimisation(limits, 0.001, velocity_horizon=HORIZON)
    previous = np.zeros(7)
    previous[0] = limits.tcp_speed / HORIZON         # joint 1 on the TCP limit the tick before
    desired = previous.copy()
    desired[0] += past * optimisation.rate_step      # within its rate step and far inside its torque limit ...
    assert desired[0] <= limits.torque_array[0] and HORIZON * desired[0] > limits.tcp_speed   # ... past the TCP limit
    desired[1] = 2.0 * optimisation.rate_step        # joint 2: two rate steps
    result = optimisation.shape(desired, previous, Q, np.zeros(7), np.zeros(7), np.eye(7), JACOBIAN)
    assert result.solved_qp
    assert HORIZON * result.torque[0] <= limits.tcp_speed * (1.0 + 1e-6)   # the TCP limit lowered joint 1
    assert result.torque[0] < desired[0] - 1e-6
    assert result.torque[1] == pytest.approx(optimisation.rate_step, abs=1e-9)
    assert result.flags & LimitFlag.TCP_SPEED, result.flags
    assert result.flags & LimitFlag.TORQUE_RATE, result.flags
