"""Every joint at once on an edge of the torque box (the heavy toy arm of test_torque_box_shaping: only the box can
bind): the QP's answer with all seven on the rate edge flags TORQUE_RATE alone (its active set), even where tau_d was
also past the torque limit; all seven on the torque edge flag TORQUE, whether the QP or a solver that gives up (the
last guard) puts them there."""
from __future__ import annotations

import numpy as np
import pytest
from test_torque_box_shaping import DT, shaped

from fic_core.limits import LimitFlag, PandaLimits
from fic_core.postural_optimisation import PosturalOptimisation


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_all_seven_joints_a_rate_step_short_of_their_demand_flag_the_rate(limits: PandaLimits, sign: float) -> None:
    optimisation = PosturalOptimisation(limits, DT)
    step = optimisation.rate_step
    torque_max = np.asarray(limits.torque, dtype=float)
    previous = np.zeros(7)
    # Twice past the torque limits: tau_d breaks both, but only the rate step shapes the answer (the torque limit is
    # slack there), so TORQUE is not among the limits that changed the command.
    desired = sign * 2.0 * torque_max
    result = shaped(optimisation, limits, desired, previous)
    np.testing.assert_allclose(result.torque, sign * np.full(7, step), atol=1e-9)
    assert result.flags == LimitFlag.TORQUE_RATE


@pytest.mark.parametrize("sign", [1.0, -1.0])
@pytest.mark.parametrize("iteration_limit", [None, 1])
def test_all_seven_joints_pushed_past_their_torque_limits_flag_the_torque(
        limits: PandaLimits, sign: float, iteration_limit: int | None) -> None:
    optimisation = (PosturalOptimisation(limits, DT) if iteration_limit is None
                    else PosturalOptimisation(limits, DT, iteration_limit=iteration_limit))
    step = optimisation.rate_step
    torque_max = np.asarray(limits.torque, dtype=float)
    previous = sign * (torque_max - 0.5 * step)
    desired = sign * (torque_max + 0.25 * step)   # past the limit, within a rate step of the last command
    result = shaped(optimisation, limits, desired, previous)
    np.testing.assert_allclose(result.torque, sign * torque_max, atol=1e-9)
    assert result.flags == LimitFlag.TORQUE
