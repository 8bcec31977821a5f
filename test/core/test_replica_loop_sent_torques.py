"""What the replica loop says about the torques it sends (fic_core.replica_loop, fic_core.loop_health): a law torque
held back at ``ready`` (its state grew older than the bound inside the tick) is a held tick, and while holding
there is no law's tick to report, so its poses and status are not due even at rates that make every tick's due;
and the loop's command gap is the time between torques that went out, the largest one kept for /diagnostics."""
from __future__ import annotations

import numpy as np
import pytest
from config_values import replica_loop_parameters

from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.replica_loop import ReplicaLoop

Q0 = np.array(NOMINAL_CONFIGURATION, dtype=float)
PERIOD = 2.0 ** -9   # [s] ~2 ms, binary-exact so that the gaps below are exact


def reporting_every(ticks: int) -> ReplicaLoop:
    """Poses and status due every ``ticks`` control ticks."""
    rate = 1.0 / PERIOD
    return ReplicaLoop(replica_loop_parameters(control_rate=rate, command_period=PERIOD, pose_rate=rate / ticks,
                                               status_rate=rate / ticks, loop_max_state_age=0.04,
                                               loop_max_tick_gap=0.04, loop_resume_ticks=5, loop_resume_ramp=0.1))


def every_tick_reports() -> ReplicaLoop:
    return reporting_every(1)


def test_poses_and_status_are_due_at_their_rate_and_not_while_holding() -> None:
    """At a quarter of the control rate: due on one healthy tick in four; on none of the held ticks of a hold."""
    replica = reporting_every(4)
    now, due = 0.0, []
    for _ in range(16):
        now += PERIOD
        step = replica.joint_state(now, now, Q0, np.zeros(7))
        assert not step.held
        due.append((step.poses_due, step.status_due))
    assert due.count((True, True)) == 4 and due.count((False, False)) == 12
    now += PERIOD
    assert replica.joint_state(now - 0.06, now, Q0, np.zeros(7)).held   # a 60 ms old state: the hold
    for _ in range(4):   # healthy states, not yet resume_ticks of them: still held
        now += PERIOD
        step = replica.joint_state(now, now, Q0, np.zeros(7))
        assert step.held and not step.poses_due and not step.status_due


def test_a_torque_held_back_when_ready_reports_no_poses_or_status() -> None:
    replica = every_tick_reports()
    now = 0.0
    for _ in range(5):
        now += PERIOD
        step = replica.ready(replica.joint_state(now, now, Q0, np.zeros(7)), now, now + PERIOD / 4)
        assert not step.held and step.poses_due and step.status_due
    now += PERIOD
    step = replica.joint_state(now, now, Q0, np.zeros(7))
    assert step.poses_due and step.status_due and not step.held   # due, until the torque is found late
    step = replica.ready(step, now, now + 0.05)
    assert step.held and replica.health.holds == 1
    assert not step.poses_due and not step.status_due


def test_the_command_gap_is_the_time_between_torques_sent() -> None:
    replica = every_tick_reports()
    now = 0.0
    for _ in range(4):
        now += PERIOD
        assert replica.joint_state(now, now, Q0, np.zeros(7)).torque is not None
    assert replica.health.command_gap == PERIOD and replica.health.max_command_gap_seen == PERIOD
    now += 3 * PERIOD   # two states lost: the next torque goes out three periods after the last
    assert replica.joint_state(now, now, Q0, np.zeros(7)).torque is not None
    now += PERIOD
    assert replica.joint_state(now, now, Q0, np.zeros(7)).torque is not None
    assert replica.health.command_gap == PERIOD
    assert replica.health.max_command_gap_seen == 3 * PERIOD
    diagnostics = replica.health.diagnostic_values()
    assert float(diagnostics["max_command_gap_ms"]) == pytest.approx(3 * PERIOD * 1e3, abs=0.05)
