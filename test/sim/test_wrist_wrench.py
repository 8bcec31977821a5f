"""The wrist F/T reading is the environment's force on the end-effector: a known press reads back within 5 %."""
import numpy as np
import pytest
from cartesian_helper import cartesian_torque

from sim_bridge.robot.mujoco_panda import PandaSimulation
from sim_bridge.robot.scenes import TABLE_TOP_HEIGHT

# A free spot on the superimposition table, away from the two obstacles.
PRESS_POINT = np.array([0.40, -0.35])


@pytest.mark.parametrize("press_force", [8.0, 20.0])
def test_pressing_the_table_with_a_known_force_reads_back_within_5_percent(press_force):
    sim = PandaSimulation("superimposition", seed=0)
    _, down = sim.tcp_pose  # keep the nominal orientation: hand pointing down
    for height in (0.30, TABLE_TOP_HEIGHT + 0.03):
        target = np.array([*PRESS_POINT, height])
        for _ in range(1500):
            sim.step(cartesian_torque(sim, target, down))
    assert np.linalg.norm(sim.ft_wrench()) == 0.0  # not touching yet
    # Press: no vertical spring, a constant downward force through J^T on top of the exact bias compensation.
    for _ in range(2000):
        sim.step(cartesian_torque(sim, target, down, force=np.array([0.0, 0.0, -press_force]),
                                  stiffness=np.array([400.0, 400.0, 0.0])))
    assert np.abs(sim.joint_velocities).max() < 1e-2  # settled
    wrench = sim.ft_wrench()
    # The table pushes up on the hand with the pressing force (environment force on the robot, base frame).
    assert wrench[2] == pytest.approx(press_force, rel=0.05)
    assert sim.tcp_pose[0][2] < TABLE_TOP_HEIGHT + 0.02


def test_free_motion_reads_zero_whatever_the_hand_weight_and_acceleration():
    sim = PandaSimulation("free_space", seed=0)
    _, down = sim.tcp_pose
    start = sim.tcp_pose[0]
    for k in range(800):  # a brisk move: a force sensor in the wrist would read the hand's weight and inertia
        sim.step(cartesian_torque(sim, start + np.array([0.1, 0.2 * np.sin(k / 100.0), -0.1]), down))
        assert not sim.ft_wrench().any()
    assert np.linalg.norm(sim.joint_velocities) > 0.1
