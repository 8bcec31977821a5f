"""The replica's own path to the postural optimisation (its fast-path verdict on floats, then ``shape_rejected``)
gives ``shape``'s answer for the same tau_d and state (docs/CONTROL_LAWS.md: the TCP speed limit, 1.7 m/s, on the
TCP velocity predicted T ahead), whichever way the TCP moves: at 1.65 m/s along each base axis, either sign, with the
FIC pulling it on toward a target 10 cm further, the command is shaped onto the cone (TCP_SPEED alone: every joint
far from its speed limit) as shape() shapes it."""
from __future__ import annotations

import numpy as np
import pytest
from test_limit_mutants import _replica

from fic_core.limits import LimitFlag, PandaLimits
from fic_core.postural_optimisation import PosturalOptimisation
from fic_core.robot_model import RobotModel

# For each axis a configuration where 1.65 m/s at the TCP along it needs at most 0.6 of every joint's speed limit
# (searched), so that the TCP speed alone binds.
CONFIGURATIONS = ([0.065, -0.61, 0.785, -1.377, -1.572, 3.314, 0.309],
                  [1.296, -1.082, 0.299, -1.36, 1.627, 1.778, 1.413],
                  [0.49, 0.594, 0.552, -0.805, -0.294, 1.751, -0.058])
SPEED = 1.65   # [m/s] at the TCP
AXES = [(axis, sign) for axis in range(3) for sign in (1.0, -1.0)]


@pytest.mark.parametrize("axis, sign", AXES, ids=[f"{'+-'[sign < 0]}{'xyz'[axis]}" for axis, sign in AXES])
def test_the_replicas_shaping_is_shapes_for_a_tcp_moving_along_each_axis(robot: RobotModel, axis: int,
                                                                         sign: float) -> None:
    limits = PandaLimits.from_robot(robot)
    direction = np.zeros(3)
    direction[axis] = sign
    q = np.array(CONFIGURATIONS[axis])
    robot.update(q, np.zeros(7))
    weights = np.diag(limits.joint_velocity_array)
    joint_direction = weights @ np.linalg.pinv(robot.tcp_jacobian[:3] @ weights) @ direction
    qd = joint_direction * SPEED / np.linalg.norm(robot.tcp_jacobian[:3] @ joint_direction)
    assert np.all(np.abs(qd) <= 0.6 * limits.joint_velocity_array)
    robot.update(q, qd)
    rotation = robot.tcp_rotation.copy()
    target = robot.tcp_position + 0.1 * direction
    jacobian, minv = robot.tcp_jacobian.copy(), robot.mass_matrix_inverse.copy()
    bias = robot.nonlinear_effects + robot.joint_damping * qd
    replica = _replica(robot)
    command = replica.command(q, qd, target, rotation)
    assert command.limit_shaping == LimitFlag.TCP_SPEED
    shaped = PosturalOptimisation(limits, replica.control_period).shape(
        command.unshaped_torque, None, q, qd, bias, minv, jacobian[:3])
    assert command.limit_shaping == shaped.flags
    np.testing.assert_allclose(command.law_torque, shaped.torque, rtol=0.0, atol=1e-9)
