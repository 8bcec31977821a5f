"""The replica's tick flags JOINT_VELOCITY however many joints are past their velocity limits, all seven at once
included, with the TCP still (a joint velocity in the null space of J_v) so that nothing but the joints' speeds is
broken: limits.py's limit_violations for the torque sent is the oracle (docs/CONTROL_LAWS.md, "The limits")."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.limits import LimitFlag, PandaLimits, limit_violations
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel


def _null_space_velocity(robot: RobotModel, q: np.ndarray, v_max: np.ndarray, past: float,
                         rng: np.random.Generator) -> np.ndarray:
    """A qd with J_v qd = 0 and every |qd_i| at least (1 + past) v_max_i."""
    jacobian = robot.update(q, np.zeros(7)).tcp_jacobian[:3]
    basis = np.linalg.svd(jacobian)[2][3:]          # the 4 right singular vectors J_v sends to zero
    best = None
    for _ in range(20):
        candidate = rng.normal(size=4) @ basis
        ratio = np.min(np.abs(candidate) / v_max)
        if best is None or ratio > best[0]:
            best = (ratio, candidate)
    return best[1] * (1.0 + past) / best[0]


@pytest.mark.parametrize("joints", [1, 3, 7])
def test_joints_past_their_velocity_limit_are_flagged_however_many(robot: RobotModel, limits: PandaLimits,
                                                                   joints: int) -> None:
    rng = np.random.default_rng(joints)
    replica = ReplicaController(robot, PoseAttractor(ForceProfile(2000.0, 0.05, 0.5, 200.0),
                                                     ForceProfile(100.0, 0.5, 0.5, 30.0)))
    q = np.array(NOMINAL_CONFIGURATION, dtype=float)
    v_max = limits.joint_velocity_array
    state = robot.update(q, np.zeros(7))
    position, rotation = state.tcp_position.copy(), state.tcp_rotation.copy()
    for past in (1e-6, 0.01, 0.3):
        qd = _null_space_velocity(robot, q, v_max, past, rng)
        scale = np.ones(7)
        scale[joints:] = 0.5 / (np.abs(qd[joints:]) / v_max[joints:])   # the joints beyond the count: half speed
        qd = qd * scale if joints < 7 else qd
        assert np.count_nonzero(np.abs(qd) > v_max * (1.0 + 1e-7)) == joints
        previous = replica.previous_torque
        command = replica.command(q, qd, position, rotation)
        expected = limit_violations(previous, command.torque, q, qd, command.tcp_speed, replica.control_period,
                                    limits)
        assert expected & LimitFlag.JOINT_VELOCITY
        assert command.limit_violations == expected, (joints, past)
