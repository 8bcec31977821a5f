"""LoopHealth.ready, the check of a law torque whose state may have grown old inside the tick, starts a hold once:
before any tick there is no clock offset and so no age to judge (nothing said, nothing counted); the age is the
time since the state less the clock offset (the link's latency is not age), so a torque ready just inside the bound
on a 1 ms latency goes out and one just past it holds; the hold it starts sends gravity alone (the state's velocity
is old) and lasts resume_ticks healthy ticks, as one that a tick starts; a torque found late while the loop already
holds starts no second hold, says nothing and keeps the first hold's reason."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.loop_health import HEALTHY, HOLDING, RESUMING, LoopHealth, LoopHealthBounds

PERIOD = 2.0 ** -9
LATENCY = 2.0 ** -10   # [s] now - state_time of every healthy tick: the clock offset
BOUNDS = LoopHealthBounds(max_state_age=0.04, max_tick_gap=0.04, resume_ticks=5, resume_ramp=0.1)


def healthy(ticks: int = 5) -> tuple[LoopHealth, float]:
    health = LoopHealth(BOUNDS)
    now = 0.0
    for _ in range(ticks):
        now += PERIOD
        assert health.tick(now, now - LATENCY) == ""
    assert health.clock_offset == LATENCY
    return health, now


def test_before_any_tick_a_torque_is_not_judged() -> None:
    health = LoopHealth(BOUNDS)
    assert health.ready(10.0, 0.0) == ""
    assert (health.state, health.holds, health.reason) == (HEALTHY, 0, "")


def test_the_age_when_ready_leaves_the_latency_out() -> None:
    health, now = healthy()
    state_time = now - LATENCY
    assert health.ready(state_time + LATENCY + 0.039, state_time) == ""
    assert health.state == HEALTHY and health.holds == 0
    assert "when its torque was ready" in health.ready(state_time + LATENCY + 0.041, state_time)
    assert health.state_age == pytest.approx(0.041, abs=1e-12)


def test_a_late_torque_holds_once_with_gravity_alone_for_resume_ticks() -> None:
    health, now = healthy()
    assert "when its torque was ready" in health.ready(now + 0.05, now - LATENCY)
    assert (health.state, health.holds) == (HOLDING, 1)
    gravity = np.array([0.0, -3.0, 0.5, 20.0, 0.6, 2.0, 0.0])
    np.testing.assert_array_equal(health.hold_command(gravity, np.full(7, 0.3)), gravity)
    reason = health.reason
    for tick in range(BOUNDS.resume_ticks):
        now += PERIOD
        health.tick(now, now - LATENCY)
        if tick < BOUNDS.resume_ticks - 1:
            assert health.state == HOLDING, tick
            assert health.ready(now + 0.05, now - LATENCY) == ""   # late again while holding: nothing new
            assert (health.holds, health.reason) == (1, reason)
    assert health.state == RESUMING


def test_a_state_exactly_max_state_age_old_is_known_fresh_for_the_next_state_gap() -> None:
    """On binary fractions: a state exactly max_state_age (1/32 s) old is inside the bound, so the next tick's state
    gap on the arm's clock is measured from it; one a hair older is not fresh and the next gap starts afresh (0).
    (Its stamp is 1/32 s plus the clock drift allowed over the tick, half a period, behind the clock.)"""
    bounds = LoopHealthBounds(max_state_age=2.0 ** -5, max_tick_gap=2.0 ** -4, resume_ticks=5, resume_ramp=0.1)
    drift = 0.5 * PERIOD
    for extra, gap in ((0.0, 2.0 ** -5 + drift + PERIOD), (2.0 ** -20, 0.0)):
        health = LoopHealth(bounds)
        now = 0.0
        for _ in range(3):
            now += PERIOD
            health.tick(now, now)
        now += PERIOD
        health.tick(now, now - 2.0 ** -5 - drift - extra)
        assert health.state_age == 2.0 ** -5 + extra
        assert health.state_fresh == (extra == 0.0)
        now += PERIOD
        health.tick(now, now)
        assert health.state_gap == gap
