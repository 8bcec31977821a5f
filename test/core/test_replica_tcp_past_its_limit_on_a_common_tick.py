"""A measured TCP speed past its limit is a violation on every tick, the common one included: tau_d passes
unshaped (the law decelerates the TCP, so its speed T ahead is inside the limit) and every joint is inside its
velocity and position limits, so only the TCP speed measured now is broken. limits.py's limit_violations for the
torque sent is the oracle (docs/CONTROL_LAWS.md, "The limits"). The joint velocity is the one with the smallest
joint speeds (relative to v_max) that moves the TCP along y at the given speed, from a linear programme."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from fic_core.limits import LimitFlag, PandaLimits, limit_violations
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel

DIRECTION = np.array([0.0, 1.0, 0.0])


def _slowest_joint_velocity(jacobian: np.ndarray, v_max: np.ndarray) -> tuple[np.ndarray, float]:
    """qd with J_v qd = DIRECTION (1 m/s) and the least max |qd_i| / v_max_i, and that ratio."""
    cost = np.r_[np.zeros(7), 1.0]
    rows = np.block([[np.eye(7), -v_max[:, None]], [-np.eye(7), -v_max[:, None]]])
    answer = linprog(cost, A_ub=rows, b_ub=np.zeros(14), A_eq=np.c_[jacobian, np.zeros(3)], b_eq=DIRECTION,
                     bounds=[(None, None)] * 8)
    assert answer.success
    return answer.x[:7], answer.x[7]


@pytest.mark.parametrize("speed", [1.69, 1.7 + 1e-6, 1.72, 1.8])
def test_a_tcp_past_its_limit_is_a_violation_on_an_unshaped_tick(robot: RobotModel, limits: PandaLimits,
                                                                 speed: float) -> None:
    q = np.array(NOMINAL_CONFIGURATION, dtype=float)
    state = robot.update(q, np.zeros(7))
    position, rotation = state.tcp_position.copy(), state.tcp_rotation.copy()
    unit, ratio = _slowest_joint_velocity(state.tcp_jacobian[:3].copy(), limits.joint_velocity_array)
    assert speed * ratio < 1.0                       # every joint inside its velocity limit
    qd = unit * speed
    replica = ReplicaController(robot, PoseAttractor(ForceProfile(2000.0, 0.05, 0.5, 200.0),
                                                     ForceProfile(100.0, 0.5, 0.5, 30.0)))
    command = replica.command(q, qd, position - 0.01 * DIRECTION, rotation)   # x_d behind: decelerating
    assert command.limit_shaping == LimitFlag.NONE   # tau_d unshaped
    assert command.tcp_speed == pytest.approx(speed, rel=1e-9)
    expected = limit_violations(None, command.torque, q, qd, command.tcp_speed, replica.control_period, limits)
    assert command.limit_violations == expected
    assert bool(expected & LimitFlag.TCP_SPEED) == (speed > limits.tcp_speed)
    assert expected & ~LimitFlag.TCP_SPEED == LimitFlag.NONE
