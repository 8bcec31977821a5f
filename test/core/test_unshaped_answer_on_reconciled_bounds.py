"""A tau_d that the postural optimisation passes unshaped is answered as such whichever test let it through: the
torque tau_d itself, no limit named, no change, no QP, nothing relaxed or clipped and no solver iteration
(ShapedTorque: "iterations: 0 on the fast path"). The case the fast tests cannot decide: a joint too fast too
close to its position limit, whose acceleration bounds conflict and are reconciled onto the position side
(``acceleration_bounds``: a_lo = a_hi), with tau_d asking exactly that acceleration. The fast tests refuse any
reconciled joint, so the flags decide, and they find nothing broken. A toy arm keeps the arithmetic exact:
M^-1 = 256 I (a power of two, so M^-1 tau_d is the bound to the bit), no bias, a TCP that does not move."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.limits import LimitFlag, PandaLimits
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.postural_optimisation import PosturalOptimisation

INVERSE_MASS_SCALE = 256.0
ROOM = 0.001   # [rad] from the position limit


@pytest.mark.parametrize("side", ["upper", "lower"])
@pytest.mark.parametrize("joint", range(7))
def test_tau_d_on_reconciled_bounds_is_answered_unshaped_with_no_iteration(limits: PandaLimits, joint: int,
                                                                           side: str) -> None:
    optimisation = PosturalOptimisation(limits, 0.001)
    q = np.array(NOMINAL_CONFIGURATION, dtype=float)
    qd = np.zeros(7)
    toward = 1.0 if side == "upper" else -1.0
    q[joint] = limits.upper_array[joint] - ROOM if side == "upper" else limits.lower_array[joint] + ROOM
    qd[joint] = toward * limits.joint_velocity_array[joint]   # on its velocity limit, toward the position limit
    low, high, _, _, reconciled = optimisation.acceleration_bounds(q, qd)
    assert reconciled and low[joint] == high[joint]            # the conflict the fast tests refuse
    desired = np.zeros(7)
    desired[joint] = low[joint] / INVERSE_MASS_SCALE          # exactly that acceleration
    assert abs(desired[joint]) <= limits.torque_array[joint]
    result = optimisation.shape(desired, None, q, qd, np.zeros(7), INVERSE_MASS_SCALE * np.eye(7),
                                np.zeros((3, 7)))
    np.testing.assert_array_equal(result.torque, desired)
    assert result.flags == LimitFlag.NONE
    assert (result.torque_change, result.solved_qp, result.relaxed, result.guard_clipped, result.iterations,
            result.fast_path) == (0.0, False, False, False, 0, False)


def test_without_a_qp_no_iteration_is_counted(limits: PandaLimits) -> None:
    """Seeded states near the limits and tau_d within a step or two of them: whenever no QP was solved, the torque
    is tau_d and no iteration is counted; whenever one was, the flags name a limit."""
    optimisation = PosturalOptimisation(limits, 0.001)
    generator = np.random.default_rng(20261207)
    span = limits.upper_array - limits.lower_array
    unshaped = shaped = 0
    for _ in range(60):
        q = limits.lower_array + span * generator.choice([0.0005, 0.05, 0.5, 0.95, 0.9995], size=7)
        qd = limits.joint_velocity_array * generator.uniform(-1.0, 1.0, size=7) * generator.choice([0.02, 1.1])
        desired = limits.torque_array * generator.uniform(-0.002, 0.002, size=7)
        result = optimisation.shape(desired, None, q, qd, np.zeros(7), INVERSE_MASS_SCALE * np.eye(7),
                                    np.zeros((3, 7)))
        if result.solved_qp:
            shaped += 1
            assert result.flags != LimitFlag.NONE
        else:
            unshaped += 1
            assert result.iterations == 0
            np.testing.assert_array_equal(result.torque, desired)
    assert unshaped and shaped


def _joint_one_reconciled(limits: PandaLimits):
    """Joint 1 ROOM below its upper limit at its velocity limit: its acceleration bounds reconciled to one value."""
    optimisation = PosturalOptimisation(limits, 0.001)
    q = np.array(NOMINAL_CONFIGURATION, dtype=float)
    qd = np.zeros(7)
    q[0] = limits.upper_array[0] - ROOM
    qd[0] = limits.joint_velocity_array[0]
    low, high, _, _, reconciled = optimisation.acceleration_bounds(q, qd)
    assert reconciled and low[0] == high[0]
    return optimisation, q, qd, low, high


@pytest.mark.parametrize("edge", [-1.0, 1.0])
def test_tau_d_exactly_on_its_rate_box_edge_beside_a_reconciled_joint_is_unshaped(limits: PandaLimits,
                                                                                  edge: float) -> None:
    """The box is closed: with the reconciled joint sending the tick to the flags, a joint whose tau_d is exactly
    one rate step from its last command (on the box edge, inside its torque limit) breaks nothing."""
    optimisation, q, qd, low, high = _joint_one_reconciled(limits)
    previous = np.zeros(7)
    previous[0] = low[0] / INVERSE_MASS_SCALE
    previous[3] = 0.5                                          # joint 4: a binary fraction, so the edge is exact
    desired = previous.copy()
    desired[3] = previous[3] + edge * optimisation.rate_step   # exactly on the box's edge
    box_low, box_high = optimisation.torque_box(previous)
    assert desired[3] == (box_high[3] if edge > 0 else box_low[3])
    inverse_mass = np.diag([INVERSE_MASS_SCALE, 1.0, 1.0, 2.0 ** -6, 1.0, 1.0, 1.0])   # powers of two: exact
    assert low[3] <= inverse_mass[3, 3] * desired[3] <= high[3]   # joint 4's acceleration inside its bounds
    result = optimisation.shape(desired, previous, q, qd, np.zeros(7), inverse_mass, np.zeros((3, 7)))
    np.testing.assert_array_equal(result.torque, desired)
    assert result.flags == LimitFlag.NONE and not result.solved_qp and result.iterations == 0


@pytest.mark.parametrize("sign", [-1.0, 1.0])
def test_tau_d_exactly_on_its_torque_limit_beside_a_reconciled_joint_is_unshaped(limits: PandaLimits,
                                                                                 sign: float) -> None:
    """With no last command the box is the torque limits, closed: a joint asking exactly +-tau_max (the reconciled
    joint sending the tick to the flags) breaks nothing and is answered unshaped."""
    optimisation, q, qd, low, high = _joint_one_reconciled(limits)
    desired = np.zeros(7)
    desired[0] = low[0] / INVERSE_MASS_SCALE
    desired[3] = sign * limits.torque_array[3]                 # exactly on the torque limit
    inverse_mass = np.diag([INVERSE_MASS_SCALE, 1.0, 1.0, 2.0 ** -6, 1.0, 1.0, 1.0])
    assert low[3] <= inverse_mass[3, 3] * desired[3] <= high[3]
    result = optimisation.shape(desired, None, q, qd, np.zeros(7), inverse_mass, np.zeros((3, 7)))
    np.testing.assert_array_equal(result.torque, desired)
    assert result.flags == LimitFlag.NONE and not result.solved_qp and result.iterations == 0
