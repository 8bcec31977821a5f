"""How close to a limit the torque box's flags call a command "on" it (postural_optimisation.py: a torque within
1e-9 N m of its bound sits on it, the slack for rounding): a command the rate step leaves a micro-newton-metre
inside the torque limit is on the rate edge alone (TORQUE_RATE), one the torque limit stops a micro-newton-metre
short of a whole rate step is on the torque edge alone (TORQUE), whether the QP or a solver that gives up (the last
guard) puts it there. The heavy toy arm of test_torque_box_shaping: only the box can bind."""
from __future__ import annotations

import numpy as np
import pytest
from test_torque_box_shaping import DT, shaped

from fic_core.limits import LimitFlag, PandaLimits
from fic_core.postural_optimisation import PosturalOptimisation

MICRO = 1e-6   # far above the 1e-9 slack, far below a rate step (1 N m)


def solvers(limits: PandaLimits) -> list[PosturalOptimisation]:
    return [PosturalOptimisation(limits, DT), PosturalOptimisation(limits, DT, iteration_limit=1)]


@pytest.mark.parametrize("joint", [0, 5])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_rate_step_ending_just_inside_the_torque_limit_is_on_the_rate_edge_alone(
        limits: PandaLimits, joint: int, sign: float) -> None:
    """The last command one step and a micro-newton-metre inside the limit, the demand half-way between a step
    from it and the limit: the answer is the step, TORQUE_RATE and not TORQUE."""
    for optimisation in solvers(limits):
        step = optimisation.rate_step
        torque_max = limits.torque[joint]
        previous, desired = np.zeros(7), np.zeros(7)
        previous[joint] = sign * (torque_max - step - MICRO)
        desired[joint] = sign * (torque_max - 0.5 * MICRO)
        assert abs(desired[joint] - previous[joint]) > step and abs(desired[joint]) < torque_max
        result = shaped(optimisation, limits, desired, previous)
        assert result.torque[joint] == pytest.approx(previous[joint] + sign * step, abs=1e-12)
        assert abs(result.torque[joint]) < torque_max - 0.5 * MICRO
        assert result.flags == LimitFlag.TORQUE_RATE, optimisation.iteration_limit


@pytest.mark.parametrize("joint", [0, 5])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_torque_limit_a_hair_short_of_a_rate_step_is_on_the_torque_edge_alone(
        limits: PandaLimits, joint: int, sign: float) -> None:
    """The last command a micro-newton-metre less than a step inside the limit, the demand just past the limit but
    within a step: the answer is the limit, TORQUE and not TORQUE_RATE."""
    for optimisation in solvers(limits):
        step = optimisation.rate_step
        torque_max = limits.torque[joint]
        previous, desired = np.zeros(7), np.zeros(7)
        previous[joint] = sign * (torque_max - step + MICRO)
        desired[joint] = sign * (torque_max + 0.5 * MICRO)
        assert abs(desired[joint] - previous[joint]) < step and abs(desired[joint]) > torque_max
        result = shaped(optimisation, limits, desired, previous)
        assert result.torque[joint] == pytest.approx(sign * torque_max, abs=1e-12)
        assert abs(result.torque[joint] - previous[joint]) < step - 0.5 * MICRO
        assert result.flags == LimitFlag.TORQUE, optimisation.iteration_limit


def test_one_joint_on_its_torque_edge_and_another_on_its_rate_edge_give_both_flags(limits: PandaLimits) -> None:
    """Joint 1 stopped at +tau_max, joint 6 a whole step down from its last command: TORQUE and TORQUE_RATE, each
    joint on its own edge (the QP's active set names both)."""
    for optimisation in solvers(limits):
        step = optimisation.rate_step
        previous, desired = np.zeros(7), np.zeros(7)
        previous[0], desired[0] = limits.torque[0] - 0.5 * step, limits.torque[0] + 0.25 * step
        previous[5], desired[5] = 0.0, -3.0 * step
        result = shaped(optimisation, limits, desired, previous)
        assert result.torque[0] == pytest.approx(limits.torque[0], abs=1e-12)
        assert result.torque[5] == pytest.approx(-step, abs=1e-12)
        assert result.flags == LimitFlag.TORQUE | LimitFlag.TORQUE_RATE, optimisation.iteration_limit
