"""The replica's command for a joint close to either of its position limits and moving toward it faster than it
can still brake (postural_optimisation's braking curve): whichever limit, whichever joint, the command is shaped
with JOINT_POSITION and the next sample's velocity is brought inside the braking velocity; the distance to the
nearer limit is what the replica hands the optimisation, so the upper limits (of joints whose lower limit is
negative) count as much as the lower ones."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.limits import LimitFlag, PandaLimits
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel

DT = 0.001


def paper_fic() -> PoseAttractor:
    return PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 10.0), ForceProfile(20.0, 0.5, 0.5, 5.0))


@pytest.mark.parametrize("side", ["upper", "lower"])
@pytest.mark.parametrize("joint", range(7))
def test_a_joint_too_fast_toward_a_near_limit_is_braked(robot: RobotModel, limits: PandaLimits, joint: int,
                                                        side: str) -> None:
    sign = 1.0 if side == "upper" else -1.0
    q = np.array(NOMINAL_CONFIGURATION, dtype=float)
    q[joint] = (limits.upper_array if sign > 0.0 else limits.lower_array)[joint] - sign * 0.02
    qd = np.zeros(7)
    qd[joint] = sign * 0.5 * limits.joint_velocity_array[joint]
    replica = ReplicaController(robot, paper_fic(), control_period=DT)
    state = robot.update(q, qd)
    brake_low, brake_high = replica.optimisation.braking_velocity(q)
    assert (qd[joint] > brake_high[joint]) if sign > 0.0 else (qd[joint] < brake_low[joint])   # cannot stop
    position, rotation = state.tcp_position.copy(), state.tcp_rotation.copy()
    replica.reset(previous_torque=state.nonlinear_effects + robot.joint_damping * qd)
    command = replica.command(q, qd, position, rotation)
    assert LimitFlag.JOINT_POSITION in command.limit_shaping
    assert command.solved_qp
    # The joint's acceleration under the command slows it toward its braking velocity.
    acceleration = state.mass_matrix_inverse @ (command.torque - state.nonlinear_effects
                                                - robot.joint_damping * qd)
    assert sign * acceleration[joint] < 0.0
