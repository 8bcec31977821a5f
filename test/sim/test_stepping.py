"""Time keeping: lockstep runs are repeatable step for step; the realtime pacer keeps a 1 kHz grid."""
import threading
import time

import numpy as np
import pytest

from fic_core.panda_description import NOMINAL_CONFIGURATION
from sim_bridge.mujoco_panda import PandaSimulation
from sim_bridge.stepping import LockstepGate, RealtimePacer, ZeroOrderHold

STEPS = 400


def _lockstep_run(scene: str, seed: int) -> np.ndarray:
    """The simulation thread publishes each state and waits for the answer; a controller thread answers it from
    the published state (a joint PD toward a moving target on top of the hold torque), as over DDS."""
    sim = PandaSimulation(scene, seed=seed)
    gate = LockstepGate()
    published: list = []
    ready = threading.Condition()
    trace = np.zeros((STEPS, 14 + 7))

    def controller() -> None:
        for k in range(STEPS):
            with ready:
                ready.wait_for(lambda: len(published) > k)
                q, qd, hold = published[k]
            target = NOMINAL_CONFIGURATION + 0.2 * np.sin(np.arange(7) + k * 0.01)
            gate.deliver(hold + 20.0 * (target - q) - 2.0 * qd)

    thread = threading.Thread(target=controller)
    thread.start()
    for k in range(STEPS):
        gate.state_published(k)
        with ready:
            published.append((sim.joint_positions, sim.joint_velocities, sim.hold_torque()))
            ready.notify_all()
        command, fresh = gate.wait(timeout=2.0)
        assert fresh
        sim.step(command)
        trace[k] = np.concatenate([sim.joint_positions, sim.joint_velocities, sim.ft_wrench(), [sim.time]])
    thread.join()
    assert gate.timeouts == 0 and gate.answered_steps == STEPS
    return trace


def test_lockstep_runs_with_the_same_seed_and_commands_are_identical_step_for_step():
    first = _lockstep_run("superimposition", seed=5)
    second = _lockstep_run("superimposition", seed=5)
    np.testing.assert_array_equal(first, second)
    assert np.abs(first[-1, :7] - first[0, :7]).max() > 0.01  # the arm did move


def test_lockstep_gate_times_out_without_an_answer_and_counts_it():
    gate = LockstepGate()
    early = np.ones(7)
    gate.deliver(early)  # arrives before the state is published: an answer to an earlier state
    gate.state_published(0)
    started = time.monotonic()
    command, fresh = gate.wait(timeout=0.02)
    assert not fresh and gate.timeouts == 1 and time.monotonic() - started >= 0.02
    assert command is early  # the latest command is still offered for the timed-out step
    gate.state_published(1)
    answer = np.zeros(7)
    threading.Timer(0.005, gate.deliver, args=(answer,)).start()
    command, fresh = gate.wait(timeout=1.0)
    assert fresh and command is answer and gate.answered_steps == 1


def test_realtime_pacer_keeps_a_1khz_grid_and_measures_lateness():
    pacer = RealtimePacer(period=0.001)
    started = time.monotonic()
    for _ in range(300):
        pacer.wait_next()
    elapsed = time.monotonic() - started
    summary = pacer.summary()
    assert summary.count == 300
    assert elapsed >= 0.299  # never runs ahead of the wall clock
    assert 0.0 <= summary.p50 <= summary.p99 <= summary.max
    assert summary.achieved_rate == pytest.approx(299 / elapsed, rel=0.1)
    assert summary.achieved_rate > 500.0  # 1 kHz nominal; a loaded 2-core VM loses some, never half


def test_realtime_pacer_restarts_its_grid_after_a_stall_instead_of_bursting():
    pacer = RealtimePacer(period=0.001, max_backlog=0.05)
    pacer.wait_next()
    time.sleep(0.12)  # a stall: 120 deadlines missed
    pacer.wait_next()
    assert pacer.overruns == 1
    started = time.monotonic()
    for _ in range(20):
        pacer.wait_next()
    assert time.monotonic() - started >= 0.019  # paced again, not 120 steps at once


def test_zero_order_hold_keeps_the_last_command_and_counts_them():
    hold = ZeroOrderHold()
    assert hold.latest() == (None, float("-inf"), 0)
    hold.update(np.ones(7), 1.5)
    command, arrival, count = hold.latest()
    assert np.array_equal(command, np.ones(7)) and arrival == 1.5 and count == 1
