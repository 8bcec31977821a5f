"""The planner's x_d'' under the same bounds as x_d' (fic_core.input_authority.SetPointAuthority, in the replica
loop): inside the workspace box about the start pose, no faster than max_offset_speed after its burst; the first
pose only clamped (the loop gives its jump back at resume_speed)."""
from __future__ import annotations

import numpy as np
import pytest
from config_values import replica_loop_parameters

from fic_core.errors import FicInputError
from fic_core.input_authority import AuthorityBounds, CommandAuthority, SetPointAuthority
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.replica_loop import ReplicaLoop

START = np.array([0.3, 0.0, 0.5])
BOUNDS = AuthorityBounds(offset_lower=(-0.2, -0.2, -0.2), offset_upper=(0.2, 0.2, 0.2), max_offset_speed=0.5,
                         max_offset_burst=0.01)
Q0 = np.array(NOMINAL_CONFIGURATION, dtype=float)
QUATERNION = (1.0, 0.0, 0.0, 0.0)


def authority() -> SetPointAuthority:
    bounded = SetPointAuthority(BOUNDS)
    bounded.start(START)
    return bounded


def test_a_pose_before_the_start_or_not_finite_is_refused() -> None:
    with pytest.raises(FicInputError, match="before the first joint state"):
        SetPointAuthority(BOUNDS).check(START, 0.0)
    with pytest.raises(FicInputError):
        authority().check([np.nan, 0.0, 0.0], 0.0)


def test_the_first_pose_is_clamped_into_the_box_about_the_start_and_not_rate_limited() -> None:
    bounded = authority()
    np.testing.assert_allclose(bounded.check(START + [1e308, 0.1, -5.0], 0.0), START + [0.2, 0.1, -0.2])
    assert bounded.clamped == 1 and bounded.rate_limited == 0 and "outside the workspace" in bounded.last_reason


def test_a_jump_is_approached_at_the_bounded_speed() -> None:
    bounded = authority()
    bounded.check(START, 0.0)
    now, previous = 0.0, START
    for _ in range(100):
        now += 0.01
        position = bounded.check(START + [0.15, 0.0, 0.0], now)   # an intruder 0.15 m away, at 100 Hz
        assert np.linalg.norm(position - previous) <= 0.5 * 0.01 + 1e-12
        previous = position
    assert bounded.rate_limited >= 25
    np.testing.assert_allclose(previous, START + [0.15, 0.0, 0.0])


def test_two_writers_flipping_x_d_pp_move_it_by_no_more_than_the_speed_allows() -> None:
    bounded = authority()
    bounded.check(START, 0.0)
    positions = [bounded.check(START + ([0.3, 0.0, 0.0] if k % 2 else [0.0, 0.0, 0.0]), 0.005 * k)
                 for k in range(1, 200)]
    assert max(np.linalg.norm(p - START) for p in positions) <= 0.01 + 0.5 * 0.005 + 1e-12


def test_the_loop_bounds_the_planner_pose_and_takes_one_sent_before_its_first_state() -> None:
    loop = ReplicaLoop(replica_loop_parameters(), authority=CommandAuthority(BOUNDS))
    loop.add_planner_pose(0, [5.0, 0.0, 0.0], QUATERNION, 0.0)   # before any state: waits for the start
    loop.joint_state(0.001, 0.001, Q0, np.zeros(7))
    start = loop.desired.start_position
    assert loop.planner_authority.clamped == 1
    loop.add_planner_pose(2_000_000, start + [0.1, 0.0, 0.0], QUATERNION, 0.002)
    # x_d'' moved from the box's edge toward the new pose by no more than the burst
    assert loop.planner_authority.rate_limited == 1
    assert loop.statistics()["clamped_planner_poses"] == "1"


def test_a_step_of_exactly_the_burst_is_taken_whole_and_one_a_hair_longer_is_rate_limited() -> None:
    """The bucket holds max_offset_burst (0.01 m) after a second's rest: a step of exactly that is within it (taken
    as asked, not counted rate-limited, no reason), the next float above it is beyond it (clamped to the burst)."""
    for length, limited in ((0.01, False), (float(np.nextafter(0.01, 1.0)), True)):
        bounded = authority()
        bounded.check(START, 0.0)
        target = START + [0.0, length, 0.0]
        position = bounded.check(target, 1.0)
        assert bounded.rate_limited == int(limited), length
        assert ("jumps beyond" in bounded.last_reason) == limited
        if limited:
            assert np.linalg.norm(position - START) <= 0.01
        else:
            np.testing.assert_array_equal(position, target)


def test_a_pose_outside_and_too_far_says_both_and_every_pose_is_counted() -> None:
    bounded = authority()
    bounded.check(START, 0.0)
    bounded.check(START + [1.0, 0.0, 0.0], 0.001)
    assert bounded.last_reason == ("x_d'' [1.3 0.  0.5] m outside the workspace about the start pose; "
                                   "x_d'' jumps beyond 0.5 m/s: clamped")
    assert (bounded.accepted, bounded.clamped, bounded.rate_limited) == (2, 1, 1)


def test_a_receiver_clock_that_goes_back_gives_x_d_pp_no_room() -> None:
    """The bucket fills with the receiver's elapsed time, never less than none: with the burst spent, a pose
    received 'before' the last one leaves x_d'' where it stands."""
    bounded = authority()
    bounded.check(START, 0.0)
    bounded.check(START + [0.0, 0.0, 0.1], 1.0)            # spends the 0.01 m burst
    held = bounded.check(START + [0.0, 0.0, 0.1], 1.0)
    np.testing.assert_array_equal(bounded.check(START + [0.0, 0.0, 0.1], 0.5), held)
