"""The replica's report of how near each joint is to its limits (ReplicaCommand, what /replica/limit_status
carries): ``joint_position_margin`` is the distance to the nearer end of the joint's range, negative past it, and
``joint_velocity_ratio`` |qd| over the joint's speed limit, in figures at states placed on known sides of the range."""
from __future__ import annotations

import numpy as np

from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel


def test_the_margins_and_speed_ratios_of_joints_placed_near_each_end(robot: RobotModel) -> None:
    replica = ReplicaController(robot, PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 30.0),
                                                     ForceProfile(20.0, 0.5, 0.5, 10.0)))
    lower, upper = replica.limits.lower_array, replica.limits.upper_array
    q = NOMINAL_CONFIGURATION.copy()
    # joint: (where, expected margin)
    placed = {0: (lower[0] + 0.125, 0.125), 1: (upper[1] - 0.25, 0.25), 3: (lower[3] - 0.0625, -0.0625),
              5: (upper[5] + 0.03125, -0.03125), 6: (0.5 * (lower[6] + upper[6]), 0.5 * (upper[6] - lower[6]))}
    for joint, (where, _) in placed.items():
        q[joint] = where
    fractions = np.array([0.5, -0.25, 0.0, 1.0, -1.5, 0.125, 0.75])
    qd = fractions * replica.limits.joint_velocity_array
    robot.update(q, qd)
    command = replica.command(q, qd, robot.tcp_position.copy(), robot.tcp_rotation.copy())
    for joint, (_, margin) in placed.items():
        assert np.isclose(command.joint_position_margin[joint], margin, rtol=0.0, atol=1e-12), joint
    np.testing.assert_allclose(command.joint_velocity_ratio, np.abs(fractions), rtol=1e-12)
