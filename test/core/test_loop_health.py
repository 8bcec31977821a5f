"""The replica watching its own loop (fic_core.loop_health, stepped by fic_core.replica_loop), on fake clocks: a law
on an old state or after a long gap is not applied, the stated hold (G(q) and joint damping) goes out instead, the
law comes back only after a run of healthy ticks, from the hold torque, blended in over the ramp."""
from __future__ import annotations

import numpy as np
import pytest
from config_values import replica_loop_parameters

from fic_core.errors import FicInputError
from fic_core.loop_health import HEALTHY, HOLD_DAMPING, HOLDING, RESUMING, LoopHealth, LoopHealthBounds
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.replica_loop import ReplicaLoop
from fic_core.robot_model import RobotModel

Q0 = np.array(NOMINAL_CONFIGURATION, dtype=float)
PERIOD = 0.002
BOUNDS = LoopHealthBounds(max_state_age=0.04, max_tick_gap=0.04, resume_ticks=5, resume_ramp=0.1)


def gravity(q: np.ndarray) -> np.ndarray:
    robot = RobotModel()
    robot.update(q, np.zeros(7))
    return robot.gravity.copy()


def test_bounds_are_checked() -> None:
    with pytest.raises(FicInputError):
        LoopHealthBounds(max_state_age=0.0)
    with pytest.raises(FicInputError):
        LoopHealthBounds(resume_ticks=0)
    with pytest.raises(FicInputError):
        LoopHealthBounds(resume_ticks=2.5)


def test_an_old_state_holds_and_the_law_comes_back_only_after_a_healthy_run_with_a_ramp() -> None:
    health = LoopHealth(BOUNDS)
    now = 0.0
    for _ in range(10):   # fresh states every 2 ms: healthy
        now += PERIOD
        assert health.tick(now, now - 0.001) == ""
        assert health.law_fraction(now) == 1.0
    now += PERIOD
    notice = health.tick(now, now - 0.046)   # 45 ms older than the 1 ms of the healthy ticks: over the bound
    # (less the clock drift allowed over the tick: 0.5 x 2 ms)
    assert health.state == HOLDING and health.holds == 1 and "44.0 ms old" in notice
    assert health.law_fraction(now) == 0.0
    for tick in range(BOUNDS.resume_ticks - 1):   # healthy again, but not for long enough yet
        now += PERIOD
        assert health.tick(now, now) == "" and health.state == HOLDING, tick
    now += PERIOD
    assert "takes over" in health.tick(now, now) and health.state == RESUMING
    assert health.resumed_at_this_tick(now) and health.law_fraction(now) == 0.0
    assert health.law_fraction(now + 0.05) == pytest.approx(0.5)
    # An unhealthy tick during the ramp holds again and restarts the count.
    now += PERIOD
    health.tick(now, now - 0.5)
    assert health.state == HOLDING and health.holds == 2
    for _ in range(BOUNDS.resume_ticks):
        now += PERIOD
        health.tick(now, now)
    start = now
    while now < start + BOUNDS.resume_ramp + PERIOD:
        now += PERIOD
        health.tick(now, now)
    assert health.state == HEALTHY and health.law_fraction(now) == 1.0
    values = health.diagnostic_values()
    assert values["holds"] == "2" and float(values["max_state_age_ms"]) == pytest.approx(499.0)   # 500 less the drift


def test_a_long_gap_between_ticks_holds_even_on_a_fresh_state() -> None:
    health = LoopHealth(BOUNDS)
    health.tick(0.0, 0.0)
    health.tick(0.039, 0.039)
    assert health.state == HEALTHY
    assert "ms apart" in health.tick(0.09, 0.09) and health.state == HOLDING
    assert health.tick_gap == pytest.approx(0.051)


def test_the_hold_is_gravity_and_damping_and_gravity_alone_on_a_stale_velocity() -> None:
    health = LoopHealth(BOUNDS)
    g, qd = gravity(Q0), np.full(7, 0.3)
    np.testing.assert_allclose(health.hold_torque(g, qd, True), g - np.array(HOLD_DAMPING) * qd)
    np.testing.assert_allclose(health.hold_torque(g, qd, False), g)


def test_command_gaps_are_measured() -> None:
    health = LoopHealth(BOUNDS)
    for now in (0.0, 0.002, 0.032, 0.034):
        health.command_sent(now)
    assert health.command_gap == pytest.approx(0.002) and health.max_command_gap_seen == pytest.approx(0.03)


# --- in the replica loop ---------------------------------------------------------------------------------------
def loop() -> ReplicaLoop:
    return ReplicaLoop(replica_loop_parameters(control_rate=500.0, command_period=0.002, loop_max_state_age=0.04,
                                           loop_max_tick_gap=0.04, loop_resume_ticks=5, loop_resume_ramp=0.1))


def test_the_loop_sends_the_hold_on_a_stale_state_and_blends_the_law_back_in_without_a_jump() -> None:
    replica = loop()
    qd = np.full(7, 0.05)
    now, law = 0.0, None
    for _ in range(50):
        now += PERIOD
        step = replica.joint_state(now, now, Q0, qd)
        assert not step.held and step.command is not None
        law = step.torque
    # A tick 20 ms later, on a state 60 ms old. No law, the hold: G(q) only (the velocity is stale too).
    now += 0.02
    step = replica.joint_state(now - 0.06, now, Q0, qd)
    assert step.held and step.command is None and not step.poses_due and not step.status_due
    np.testing.assert_allclose(step.torque, gravity(Q0))
    assert replica.health.holds == 1 and replica.statistics()["loop_holds"] == "1"
    assert any(level == "warning" and "unhealthy" in text for level, text in step.notices)
    # Another stale tick while held: nothing is sent (the robot's watchdog holds on its own state).
    now += PERIOD
    stale = replica.joint_state(now - 0.06, now, Q0, qd)
    assert stale.held and stale.torque is None and replica.health.holds == 1
    # After a long gap the state's age is not known: no damping on its velocity either.
    now += 0.1
    gap = replica.joint_state(now, now, Q0, qd)
    assert gap.held and gap.torque is None and replica.health.holds == 1 and not replica.health.state_fresh
    ticks_before = replica.controller.ticks
    sent = [step.torque]
    for _ in range(4):   # healthy ticks, still held: gravity and damping on the fresh state
        now += PERIOD
        step = replica.joint_state(now, now, Q0, qd)
        assert step.held
        np.testing.assert_allclose(step.torque, gravity(Q0) - np.array(HOLD_DAMPING) * qd)
        sent.append(step.torque)
    assert replica.controller.ticks == ticks_before   # no law ran while held
    # The fifth healthy tick: the law again, started afresh, its first torque the hold's (fraction 0), then a ramp.
    while len(sent) < 200:
        now += PERIOD
        step = replica.joint_state(now, now, Q0, qd)
        assert not step.held
        sent.append(step.torque)
    np.testing.assert_allclose(sent[5], sent[4])
    steps = np.abs(np.diff(np.array(sent[4:]), axis=0)).max(axis=1)
    # The blend moves from the hold to the law by at most (law - hold) * PERIOD / ramp per tick.
    assert steps.max() <= np.abs(law - sent[4]).max() * PERIOD / 0.1 + 1e-6
    np.testing.assert_allclose(sent[-1], law, atol=1e-6)
    assert replica.health.state == HEALTHY


def test_a_rejected_state_while_held_repeats_the_hold() -> None:
    replica = loop()
    replica.joint_state(0.0, 0.0, Q0, np.zeros(7))
    step = replica.joint_state(0.002, 0.1, Q0, np.zeros(7))
    assert step.held
    np.testing.assert_allclose(replica.refuse_joint_state(), step.torque)


def test_stamps_behind_the_clock_age_against_the_offset_and_a_robot_stall_takes_it_afresh() -> None:
    """A simulated robot that stalled 300 ms has stamps 300 ms behind the wall clock: that is a long gap, at which
    the offset is taken afresh, not an old state; states queued behind a busy replica still age against it."""
    health = LoopHealth(BOUNDS)
    now = 100.0
    for _k in range(10):
        now += PERIOD
        health.tick(now, now - 100.0 - 0.001)   # stamps on another time line, 1 ms latency
    assert health.state == HEALTHY and health.state_age == pytest.approx(0.0)
    now += 0.3   # the robot stalled: no state for 300 ms, then states whose stamps lag 300 ms more
    health.tick(now, now - 100.3 - 0.001)
    assert health.state == HOLDING and "apart" in health.reason and health.state_age == pytest.approx(0.0)
    for _ in range(BOUNDS.resume_ticks):
        now += PERIOD
        health.tick(now, now - 100.3 - 0.001)
    assert health.state == RESUMING
    now += PERIOD
    health.tick(now, now - 100.3 - 0.06)   # a state that waited 59 ms longer in the replica's queue: old
    assert health.state == HOLDING and health.state_age == pytest.approx(0.059 - 0.5 * PERIOD)


def test_a_torque_whose_state_grew_old_inside_the_tick_is_not_sent() -> None:
    """A replica preempted inside its tick: the law's torque is ready 50 ms after its state. The hold's gravity goes
    out in its place, and the loop holds from there on."""
    replica = loop()
    now = 0.0
    for _ in range(10):
        now += PERIOD
        step = replica.ready(replica.joint_state(now, now, Q0, np.zeros(7)), now, now + 0.001)
        assert not step.held
    now += PERIOD
    step = replica.ready(replica.joint_state(now, now, Q0, np.full(7, 0.1)), now, now + 0.05)
    assert step.held and replica.health.holds == 1 and "when its torque was ready" in replica.health.reason
    np.testing.assert_allclose(step.torque, gravity(Q0))
    assert any("unhealthy" in text for _, text in step.notices)
    step = replica.joint_state(now + PERIOD, now + PERIOD, Q0, np.zeros(7))
    assert step.held   # healthy again, but only after resume_ticks


def test_stamps_drifting_behind_the_clock_are_not_old_but_a_queued_state_is() -> None:
    """A simulated robot at a real-time factor of 0.8 publishes every 2 ms of the wall clock a state 1.6 ms later
    on its own time line: no hold in 5 s; a state that waited 50 ms in a queue still holds."""
    health = LoopHealth(BOUNDS)
    now, stamp = 0.0, 0.0
    for _ in range(2500):
        now, stamp = now + PERIOD, stamp + 0.8 * PERIOD
        health.tick(now, stamp)
    assert health.holds == 0 and now - stamp > 0.9   # a second behind, no hold
    health.tick(now + PERIOD, stamp + 0.8 * PERIOD - 0.05)
    assert health.state == HOLDING and health.state_age > 0.045


def test_the_bounds_cannot_be_changed_behind_their_check() -> None:
    """The bounds are checked once, when made; a frozen dataclass keeps a later assignment (a node's parameter
    callback, say) from slipping an unchecked bound in: a change goes through a new, checked LoopHealthBounds."""
    import dataclasses

    with pytest.raises(dataclasses.FrozenInstanceError):
        BOUNDS.max_tick_gap = -1.0   # type: ignore[misc]


# --- the bounds' ends, on binary fractions (each difference exact) -------------------------------------------------
EXACT = LoopHealthBounds(max_state_age=2 ** -5, max_tick_gap=2 ** -4, resume_ticks=1, resume_ramp=0.0)


def test_a_state_exactly_max_state_age_old_and_ticks_exactly_max_tick_gap_apart_are_healthy() -> None:
    """The bounds are the oldest state and the longest gap the law may still run on; past either one, it holds.
    (The clock offset starts at 0 and may rise by half the tick gap: CLOCK_DRIFT_ALLOWANCE.)"""
    health = LoopHealth(EXACT)
    health.tick(1.0, 1.0)
    health.tick(1.0625, 1.0625)                                    # ticks exactly max_tick_gap apart
    assert health.state == HEALTHY and health.tick_gap == 2 ** -4
    assert health.state_fresh                                      # not a long gap: the state's age is known
    now = 1.0625 + 2 ** -8
    assert health.tick(now, now - 2 ** -5 - 2 ** -9) == ""          # raw 2^-5 + 2^-9, less the drift 2^-9
    assert health.state == HEALTHY and health.state_age == 2 ** -5 and health.state_fresh
    notice = health.tick(now + 2 ** -4 + 2 ** -20, now + 2 ** -4 + 2 ** -20)
    assert health.state == HOLDING and "ms apart" in notice
    late = LoopHealth(EXACT)
    late.tick(1.0, 1.0)
    late.tick(1.0 + 2 ** -8, 1.0 + 2 ** -8 - 2 ** -5 - 2 ** -9 - 2 ** -20)
    assert late.state == HOLDING and not late.state_fresh and "old" in late.reason


def test_the_states_of_two_ticks_exactly_max_tick_gap_apart_on_the_arms_clock_are_healthy() -> None:
    """The state gap is measured from a tick whose state was known fresh (not the first one)."""
    health = LoopHealth(EXACT)
    health.tick(1.0, 1.0)
    health.tick(1.0078125, 1.0078125)
    health.tick(1.03125, 1.0078125 + 2 ** -4)                      # the arm 1/16 s on, the receiver less
    assert health.state == HEALTHY and health.state_gap == 2 ** -4
    health.tick(1.0390625, 1.0078125 + 2 ** -3 + 2 ** -20)
    assert health.state == HOLDING and "on the arm's clock" in health.reason


def test_with_no_ramp_the_law_is_whole_at_once_and_one_healthy_tick_resumes() -> None:
    health = LoopHealth(EXACT)
    health.tick(1.0, 1.0)
    health.tick(1.5, 1.5)                              # a long gap: held
    assert health.holding and health.law_fraction(1.5) == 0.0
    assert "takes over" in health.tick(1.515625, 1.515625)
    assert health.law_fraction(1.515625) == 1.0
    health.tick(1.53125, 1.53125)
    assert health.state == HEALTHY


def test_a_non_finite_clock_holds_and_a_not_a_number_age_is_not_late() -> None:
    health = LoopHealth(EXACT)
    health.tick(1.0, 1.0)
    assert health.ready(1.0, float("nan")) == "" and health.state == HEALTHY
    assert health.ready(1.0 + 2 ** -5, 1.0) == ""                # exactly the bound when ready: sent
    assert "when its torque was ready" in health.ready(1.0 + 2 ** -5 + 2 ** -20, 1.0)
    other = LoopHealth(EXACT)
    other.tick(1.0, 1.0)
    other.tick(1.0 + 2 ** -6, float("inf"))
    assert other.holding and other.state_age == float("inf")


def test_before_any_tick_the_diagnostics_say_none() -> None:
    values = LoopHealth(EXACT).diagnostic_values()
    assert values["clock_offset_ms"] == "none" and values["last_hold_reason"] == "none" and values["holds"] == "0"
    assert values["state"] == HEALTHY


def test_the_diagnostics_give_each_figure_in_milliseconds_and_the_hold_its_reason() -> None:
    """Ticks on binary-exact clocks (EXACT's bounds: 31.25 ms of age, 62.5 ms between ticks), 15.6 ms apart after
    the first two: the clock offset (0.98 ms) may rise by half the time since the last tick (CLOCK_DRIFT_ALLOWANCE),
    so a state stamped 54.7 ms before the tick is 45.9 ms old: the hold begins once, naming the age and its bound,
    and the next tick on the same state (53.7 ms old, the offset risen to 16.6 ms) says nothing new. Every figure
    of the status in ms with one decimal, the maxima kept; the state gap is 0 while no state was known fresh before
    (the first tick's)."""
    health = LoopHealth(EXACT)
    health.tick(1.0, 1.0 - 2 ** -10)                    # offset 0.98 ms
    health.command_sent(1.0)
    health.tick(1.0 + 2 ** -7, 1.0 + 2 ** -7 - 2 ** -10)   # 7.8 ms later on both clocks
    health.command_sent(1.0 + 2 ** -6)                  # 15.6 ms after the last command
    notice = health.tick(1.0 + 2 ** -7 + 2 ** -6, 1.0 - 2 ** -5)   # 15.6 ms later, on a state from before
    assert health.holding and health.holds == 1
    assert health.reason == "state 45.9 ms old (bound 31.25 ms)"
    assert notice == ("replica loop unhealthy: state 45.9 ms old (bound 31.25 ms); holding (gravity and joint "
                      "damping) until 1 healthy ticks")
    assert health.tick(1.0 + 2 ** -7 + 2 ** -5, 1.0 - 2 ** -5) == ""   # still old: no second notice
    assert health.holds == 1
    health.held_tick()
    health.held_tick()
    assert health.diagnostic_values() == {
        "state": HOLDING, "state_age_ms": "53.7", "clock_offset_ms": "16.6", "tick_gap_ms": "15.6",
        "command_gap_ms": "15.6", "max_state_age_ms": "53.7", "max_tick_gap_ms": "15.6", "max_state_gap_ms": "0.0",
        "max_command_gap_ms": "15.6", "holds": "1", "held_ticks": "2", "last_hold_reason": health.reason}
