"""The lockstep barrier for the operator's side (sim_bridge/robot/peer_barrier.py), with real threads."""
from __future__ import annotations

import threading
import time

import pytest

from fic_core.errors import FicInputError
from sim_bridge.robot.peer_barrier import PeerBarrier


def test_a_peer_that_has_not_published_is_not_waited_for() -> None:
    barrier = PeerBarrier(["/master/teleop_command"], max_lag=0.03, timeout=5.0)
    assert barrier.wait(10.0) == []
    assert barrier.waits == 0 and barrier.wait_time == 0.0  # counted, not timed: a loaded machine stretches time


def test_an_expected_peer_holds_the_step_from_its_start_until_its_first_stamp() -> None:
    barrier = PeerBarrier(["/haptic/pose"], max_lag=0.03, timeout=5.0)
    barrier.expect("/haptic/pose", 0.0)
    assert barrier.wait(0.03) == [] and barrier.waits == 0   # within max_lag of the start: no wait

    def publisher() -> None:   # the peer's first message, once its clock has moved
        time.sleep(0.1)
        barrier.stamp("/haptic/pose", 0.004)
    thread = threading.Thread(target=publisher)
    thread.start()
    assert barrier.wait(0.031) == []   # held until the first stamp came
    thread.join()
    assert barrier.waits == 1 and barrier.newest("/haptic/pose") == 0.004
    barrier.expect("/haptic/pose", 0.0)   # a stamp it published is kept
    assert barrier.newest("/haptic/pose") == 0.004
    with pytest.raises(FicInputError, match="not one of the peers"):
        barrier.expect("/other", 0.0)


def test_the_step_waits_until_the_peer_catches_up() -> None:
    barrier = PeerBarrier(["/a", "/b"], max_lag=0.03, timeout=5.0)
    barrier.stamp("/a", 0.5)
    barrier.stamp("/b", 0.995)

    released = threading.Event()
    released_by: list[float | None] = []

    def publisher() -> None:  # /a catches up in steps, from another thread, as a subscriber callback would
        for stamp in (0.8, 0.9, 0.96):
            time.sleep(0.05)
            barrier.stamp("/a", stamp)
        released.wait(0.05)  # a step released by 0.96 (wrongly) is seen with 0.96 as /a's newest
        barrier.stamp("/a", 0.98)

    thread = threading.Thread(target=publisher)
    started = time.monotonic()
    thread.start()
    assert barrier.wait(1.0) == []   # released by 0.98 >= 1.0 - 0.03, not by 0.96
    released_by.append(barrier.newest("/a"))
    released.set()
    waited = time.monotonic() - started
    thread.join()
    assert released_by == [0.98]
    # The publisher slept 3 x 50 ms before its last stamps; the barrier's own wait lies inside the test's.
    assert barrier.waits == 1 and 0.15 <= barrier.wait_time <= waited, (barrier.wait_time, waited)
    assert barrier.newest("/a") == 0.98


def test_a_peer_within_its_lag_does_not_hold_the_step() -> None:
    barrier = PeerBarrier(["/a"], max_lag=0.03, timeout=5.0)
    barrier.stamp("/a", 0.975)
    assert barrier.wait(1.0) == []
    assert barrier.waits == 0 and barrier.wait_time == 0.0


def test_a_dead_peer_costs_one_timeout_then_is_not_waited_for_until_it_catches_up() -> None:
    barrier = PeerBarrier(["/dead", "/alive"], max_lag=0.03, timeout=0.2)
    barrier.stamp("/dead", 0.1)
    barrier.stamp("/alive", 1.0)
    started = time.monotonic()
    assert barrier.wait(1.0) == ["/dead"]
    assert time.monotonic() - started >= 0.2 and barrier.wait_time >= 0.2  # one whole timeout
    assert barrier.stalled == ("/dead",) and barrier.stalls == 1 and barrier.waits == 1
    for step in range(1, 200):   # the next steps do not wait for it
        barrier.stamp("/alive", 1.0 + step * 0.001)
        assert barrier.wait(1.0 + step * 0.001) == []
    assert barrier.waits == 1 and barrier.stalls == 1
    # It comes back and catches up: it is waited for again.
    barrier.stamp("/dead", 1.2)
    assert barrier.wait(1.2) == [] and barrier.stalled == ()
    started = time.monotonic()
    assert sorted(barrier.wait(1.5)) == ["/alive", "/dead"]  # both behind now: one timeout for the two
    assert time.monotonic() - started >= 0.15 and barrier.stalls == 3


def test_interrupt_wakes_a_waiting_step() -> None:
    barrier = PeerBarrier(["/a"], max_lag=0.0, timeout=30.0)
    barrier.stamp("/a", 0.0)
    threading.Timer(0.1, barrier.interrupt).start()
    assert barrier.wait(5.0) == []   # a timeout would have named /a as stalled (30 s)
    assert barrier.waits == 1 and barrier.stalls == 0 and barrier.stalled == ()


@pytest.mark.parametrize("topics, lag, timeout", [(["/a", "/a"], 0.03, 1.0), ([""], 0.03, 1.0),
                                                  (["/a"], float("nan"), 1.0), (["/a"], -0.1, 1.0),
                                                  (["/a"], 0.03, 0.0)])
def test_bad_settings_are_refused(topics, lag, timeout) -> None:
    with pytest.raises(FicInputError):
        PeerBarrier(topics, max_lag=lag, timeout=timeout)
