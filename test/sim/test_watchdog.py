"""The command watchdog holds the arm on stale commands, says so once, and releases on fresh commands."""
import numpy as np
import pytest

from fic_core.errors import FicInputError
from sim_bridge.robot.mujoco_panda import PandaSimulation
from sim_bridge.robot.watchdog import CommandWatchdog


def test_engages_once_when_stale_and_releases_on_a_fresh_command():
    watchdog = CommandWatchdog(timeout=0.05)
    start = watchdog.check(0.0)
    assert watchdog.holding and start is not None and start.engaged  # held until the first command
    assert watchdog.check(0.001) is None  # said once
    released = watchdog.command_received(0.010)
    assert released is not None and not released.engaged and not watchdog.holding
    events = []
    for k in range(11, 200):  # commands every ms until 0.1 s, then silence
        now = k * 0.001
        if now <= 0.1:
            assert watchdog.command_received(now) is None
        event = watchdog.check(now)
        if event is not None:
            events.append(event)
    assert len(events) == 1 and events[0].engaged and watchdog.holding
    assert events[0].time == pytest.approx(0.151) and events[0].command_age > 0.05
    assert watchdog.engagements == 1
    back = watchdog.command_received(0.3)
    assert back is not None and not back.engaged and back.command_age == pytest.approx(0.2)
    assert watchdog.check(0.3005) is None and not watchdog.holding


def test_timeout_must_be_positive_and_finite():
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(FicInputError, match="command_timeout"):
            CommandWatchdog(timeout=bad)


def test_hold_torque_brings_a_moving_arm_to_rest_where_it_is():
    sim = PandaSimulation("free_space", seed=0)
    for _ in range(150):  # swing the arm: 30 N m on the shoulder and elbow
        sim.step(sim.hold_torque() + np.array([30.0, 0.0, 0.0, -30.0, 0.0, 0.0, 0.0]))
    moving = np.abs(sim.joint_velocities).max()
    assert moving > 0.5
    for _ in range(1500):
        sim.step(sim.hold_torque())
    assert np.abs(sim.joint_velocities).max() < 1e-3 * moving
    resting = sim.joint_positions
    for _ in range(500):  # and stays there: gravity is compensated, nothing drifts
        sim.step(sim.hold_torque())
    assert np.abs(sim.joint_positions - resting).max() < 1e-4


def test_a_torque_on_a_state_older_than_the_bound_is_refused_and_counted():
    from sim_bridge.robot.watchdog import CommandStateAge

    rule = CommandStateAge(0.02)
    assert rule.admits(1.0, 1.019) and rule.admits(1.0, 1.0) and rule.refused == 0
    assert not rule.admits(1.0, 1.0201) and rule.refused == 1
    nanoseconds = CommandStateAge(20_000_000)   # robot_node's: on its stamp grid
    assert nanoseconds.admits(1_000_000_000, 1_020_000_000) and not nanoseconds.admits(1_000_000_000, 1_020_000_001)
    assert CommandStateAge(float("inf")).admits(0.0, 1e9)   # the runner's "no such rule"
