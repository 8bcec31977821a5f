"""``state_sent(torque, time)`` (replica.py): the loop sent another torque in place of the last command's, at
``time``; the torque-rate bound continues from that torque and that time, so the next torque sent moves from it by
at most torque_rate x the time since it (torque_slew.py: at least one command period). With ``time`` None the time
of the last command is kept. A 250 Hz law answering 1 kHz joint states, so that the slew, not the law's 4 ms rate
box, is what bounds the step: the law pulls back toward gravity's torque, 6 N m from the stated one, by a whole
4 N m box."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel

RATE = 1000.0            # [N m/s] the Panda's torque-rate limit
CONTROL_PERIOD = 0.004   # [s]
COMMAND_PERIOD = 0.001   # [s]
ROUND_OFF = 1e-9         # [N m]
OFFSET = np.array([6.0, -6.0, 6.0, -6.0, 0.5, -0.5, 0.25])   # [N m] the stated torque, from gravity's


def _started(robot: RobotModel) -> tuple[ReplicaController, np.ndarray, np.ndarray, np.ndarray]:
    robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    position, rotation, gravity = robot.tcp_position.copy(), robot.tcp_rotation.copy(), robot.nonlinear_effects.copy()
    replica = ReplicaController(robot, PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 30.0),
                                                     ForceProfile(20.0, 0.5, 0.5, 10.0)),
                                control_period=CONTROL_PERIOD, command_period=COMMAND_PERIOD)
    replica.reset(previous_torque=gravity)
    replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation, time=0.0)
    return replica, position, rotation, gravity


@pytest.mark.parametrize("stated_at, next_at", [(0.001, 0.002), (0.001, 0.0035), (0.0, 0.003), (0.002, 0.003)])
def test_the_next_step_is_bounded_by_the_time_since_the_stated_torque(
        robot: RobotModel, stated_at: float, next_at: float) -> None:
    replica, position, rotation, gravity = _started(robot)
    stated = gravity + OFFSET
    replica.state_sent(stated, stated_at)
    command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation, time=next_at)
    allowed = RATE * max(COMMAND_PERIOD, next_at - stated_at)
    assert np.abs(command.law_torque - stated).max() > allowed   # the law asks more than the slew allows
    assert np.abs(command.torque - stated).max() == pytest.approx(allowed, abs=ROUND_OFF)


@pytest.mark.parametrize("next_at", [0.002, 0.003])
def test_a_torque_stated_without_a_time_keeps_the_last_commands_time(robot: RobotModel, next_at: float) -> None:
    replica, position, rotation, gravity = _started(robot)   # its last command at 0 s
    stated = gravity + OFFSET
    replica.state_sent(stated, None)
    np.testing.assert_array_equal(replica.previous_torque, stated)
    command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation, time=next_at)
    assert np.abs(command.law_torque - stated).max() > RATE * next_at
    assert np.abs(command.torque - stated).max() == pytest.approx(RATE * next_at, abs=ROUND_OFF)
