"""The run verdict of a velocity-mode run (E2's travel): the command is the planner plus the x_d' the master sent, one
delay later, not the hand's target (a velocity command, Eq. 3); an offset-mode run keeps the hand's target."""
from __future__ import annotations

import numpy as np

from fic_core.teleoperation import TeleoperationMode
from fic_teleop_experiments.in_process import RunResult
from fic_teleop_tools.verdict.run_verdict import VerdictInput, judge

DELAY = 0.2
RATE = 100.0
DURATION = 24.0


def _travel_run(replica_follows: bool, mode: TeleoperationMode = TeleoperationMode.VELOCITY) -> RunResult:
    """The hand holds the handle 2 cm out (velocity mode) and x_d' travels 0.4 m over 20 s; the replica's TCP
    follows x_d one delay and a 2 mm lag behind, or stays where it started (parked)."""
    time = np.arange(0.0, DURATION, 1.0 / RATE)
    n = time.size
    planner = np.tile([0.4, 0.0, 0.3], (n, 1))
    travel = np.clip(time - 2.0, 0.0, 20.0) / 20.0 * 0.4
    sent = np.column_stack([travel, np.zeros(n), np.zeros(n)])
    target = np.column_stack([np.where((time > 2.0) & (time < 22.0), 0.02, 0.0), np.zeros(n), np.zeros(n)])
    received = np.column_stack([np.interp(time - DELAY, time, sent[:, 0]), np.zeros(n), np.zeros(n)])
    desired = planner + received
    tcp = desired - [0.002, 0.0, 0.0] if replica_follows else np.tile(desired[0], (n, 1))
    return RunResult(time=time, desired=desired, tcp=tcp, force=np.zeros((n, 3)), offset=received, objects={},
                     wall_s=1.0, simulated_s=DURATION, limit_violations=0, shaped_ticks=0, master=target.copy(),
                     planner=planner, arm_kinetic_energy=np.full(n, 1e-4), handle_kinetic_energy=np.full(n, 1e-5),
                     operator_target=target, command_mode=np.full(n, int(mode)), sent_offset=sent)


def _parked(result: RunResult) -> list[str]:
    return [reason for reason in judge(VerdictInput.from_run_result(result, one_way_delay=DELAY)).stable_reasons
            if reason.startswith("parked")]


def test_a_velocity_mode_run_that_follows_its_command_is_not_parked():
    result = _travel_run(replica_follows=True)
    converted = VerdictInput.from_run_result(result, one_way_delay=DELAY)
    assert np.allclose(converted.command, result.desired)
    assert _parked(result) == []


def test_a_velocity_mode_run_whose_replica_stays_behind_is_parked():
    reasons = _parked(_travel_run(replica_follows=False))
    assert any("|x_R - command|" in reason for reason in reasons)


def test_the_same_series_in_offset_mode_is_judged_against_the_hand_target():
    """Recorded as offset mode the command is the planner plus the hand's target: the 0.4 m travel is then far from
    it, which is what the velocity-mode runs were wrongly judged by."""
    result = _travel_run(replica_follows=True, mode=TeleoperationMode.OFFSET)
    converted = VerdictInput.from_run_result(result, one_way_delay=DELAY)
    later = np.interp(result.time - DELAY, result.time, result.operator_target[:, 0])
    assert np.array_equal(converted.command[:, 0], result.planner[:, 0] + later)
    assert any("|x_R - command|" in reason for reason in _parked(result))
