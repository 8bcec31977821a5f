"""The two ways a starved graph swung the simulated wrist past its speed while the replica's loop watch said it was
healthy (docs/RESULTS.md, "Stress"), each closed in the loop watch (fic_core.loop_health, fic_core.replica_loop):

- a robot that fell behind steps its backlog in a burst on the last torque: ticks at most 50 ms apart on the
  replica's clock acted on states 54-66 ms apart on the arm's, and the law on that sample-and-hold rang joint 6 up to
  1.05 x its datasheet speed. The loop now holds on the gap between its ticks' states too;
- the law resumed after a hold onto the error the hold left (the set-points moved on, 225 mm after 6 s), and its
  saturated force took joint 6 to 0.73 x its speed within 0.3 s. x_d now starts at the TCP at the resume and the
  difference is given back at resume_speed."""
from __future__ import annotations

import numpy as np
import pytest
from config_values import replica_loop_parameters

from fic_core.loop_health import HEALTHY, HOLDING, RESUMING, LoopHealth, LoopHealthBounds
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.replica_loop import ReplicaLoop
from fic_core.robot_model import RobotModel

Q0 = np.array(NOMINAL_CONFIGURATION, dtype=float)
PERIOD = 0.002
BOUNDS = LoopHealthBounds(max_state_age=0.04, max_tick_gap=0.05, resume_ticks=5, resume_ramp=0.1)


def test_states_further_apart_on_the_arms_clock_than_the_bound_hold_though_the_ticks_were_not() -> None:
    """Ticks 20 ms apart on the replica's clock whose states are 60 ms apart: the robot ran its backlog on one
    torque."""
    health = LoopHealth(BOUNDS)
    now = state = 0.0
    for _ in range(10):
        now += 0.02
        state += 0.02
        assert health.tick(now, state) == "" and health.state == HEALTHY
    now += 0.02
    state += 0.06
    notice = health.tick(now, state)
    assert health.state == HOLDING and health.holds == 1
    assert "60.0 ms apart on the arm's clock" in notice
    assert health.state_gap == pytest.approx(0.06) and health.tick_gap == pytest.approx(0.02)
    assert health.diagnostic_values()["max_state_gap_ms"] == "60.0"
    # A robot that stalled (no states, then its stamps resume where they stopped) is a long gap of the receiver's
    # clock only, and states a robot published late but in order are no gap on the arm's clock.
    stalled = LoopHealth(BOUNDS)
    stalled.tick(0.0, 0.0)
    stalled.tick(0.002, 0.002)
    stalled.tick(0.302, 0.004)
    assert stalled.state == HOLDING and "control ticks 300.0 ms apart" in stalled.reason
    assert stalled.state_gap == pytest.approx(0.002)
    # The first state of a run may have waited in the reader's queue while the process started: the gap to the
    # next one is no torque the arm ran on (none was sent before), nor is the gap after a long one.
    starting = LoopHealth(BOUNDS)
    starting.tick(10.0, 9.946)
    assert starting.tick(10.004, 10.0) == "" and starting.state == HEALTHY
    starting.tick(10.2, 10.196)   # a long gap: held, and its state's age is not known
    for k in range(BOUNDS.resume_ticks):   # the next state 62 ms on: not a gap the arm ran one torque over
        starting.tick(10.202 + 0.002 * k, 10.258 + 0.002 * k)
    assert starting.holds == 1 and starting.state == RESUMING


def _planner_pose(replica: ReplicaLoop, position: np.ndarray, now: float) -> None:
    replica.add_planner_pose(int(round(now * 1e9)), position, (1.0, 0.0, 0.0, 0.0), now)


def test_the_law_resumes_at_the_tcp_and_gives_the_set_points_progress_back_at_resume_speed() -> None:
    replica = ReplicaLoop(replica_loop_parameters(control_rate=500.0, command_period=PERIOD, loop_max_state_age=0.04,
                                              loop_max_tick_gap=0.05, loop_resume_ticks=5, loop_resume_ramp=0.1,
                                              resume_speed=0.1, use_planner_orientation=False))
    robot = RobotModel()
    robot.update(Q0, np.zeros(7))
    tcp = robot.tcp_position.copy()
    now = 0.0
    for _ in range(300):   # 0.6 s at the start pose: the planner's first pose given back already
        now += PERIOD
        _planner_pose(replica, tcp, now)
        assert not replica.joint_state(now, now, Q0, np.zeros(7)).held
    # A hold of 2.1 s (ticks 60 ms apart) while the planner's x_d'' moves 0.21 m along x at 0.1 m/s.
    target = tcp.copy()
    for _ in range(35):
        for _ in range(6):
            now += 0.01
            target[0] += 0.1 * 0.01
            _planner_pose(replica, target, now)
        assert replica.joint_state(now, now, Q0, np.zeros(7)).held
    assert replica.health.holds == 1
    commands = []
    while len(commands) < 500:   # healthy again: 5 held ticks, then the law
        now += PERIOD
        _planner_pose(replica, target, now)
        step = replica.joint_state(now, now, Q0, np.zeros(7))
        if step.command is not None:
            commands.append(np.array(step.command.desired_position_values, dtype=float))
    # The law's first x_d is the TCP, not the target 0.2 m away; it then closes on the target at 0.1 m/s.
    np.testing.assert_allclose(commands[0], tcp, atol=1e-9)
    steps = np.linalg.norm(np.diff(np.array(commands), axis=0), axis=1)
    assert steps.max() <= 0.1 * PERIOD + 1e-9
    assert np.linalg.norm(commands[-1] - tcp) == pytest.approx(0.1 * PERIOD * 499, abs=1e-3)   # 0.1 m/s, 1 s
    assert replica.desired.anchored
