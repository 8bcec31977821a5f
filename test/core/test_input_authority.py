"""fic_core.input_authority: what a teleoperation command may ask, and one owner per robot stream."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.errors import FicInputError
from fic_core.input_authority import (
    AUTHORITY_PARAMETERS,
    AuthorityBounds,
    AuthorityParameters,
    CommandAuthority,
    RobotStreamGuard,
)

NOW = 1.7e9  # a wall-clock time, as in a realtime run


def command(**overrides) -> dict:
    values = dict(stamp=NOW - 0.2, now=NOW, mode=0, haptic_gain=0.5, workspace_scale=1.0, velocity_gain=2.0,
                  handle_position=[0.01, 0.0, 0.0], desired_offset=[0.01, 0.0, 0.0])
    values.update(overrides)
    return values


def test_a_normal_command_is_accepted_unchanged() -> None:
    authority = CommandAuthority()
    verdict = authority.check(**command())
    assert verdict.accepted and not verdict.clamped and verdict.reason == ""
    np.testing.assert_array_equal(verdict.offset, [0.01, 0.0, 0.0])


@pytest.mark.parametrize("field, value, words", [
    ("mode", 7, "mode 7"),
    ("haptic_gain", 50.0, "K_H 50"),
    ("haptic_gain", -0.1, "K_H -0.1"),
    ("velocity_gain", 1.0e6, "k_v 1e+06"),
    ("workspace_scale", 0.0, "s_M 0"),
    ("handle_position", [1.0e308, 0.0, 0.0], "x_M"),
    ("desired_offset", [math.nan, 0.0, 0.0], "not finite"),
    ("haptic_gain", math.inf, "not finite"),
    ("stamp", NOW + 1.0e6, "future"),
    ("stamp", 0.0, "in the past"),
])
def test_malformed_or_mistimed_commands_are_refused_with_a_reason(field, value, words) -> None:
    authority = CommandAuthority()
    verdict = authority.check(**command(**{field: value}))
    assert not verdict.accepted and verdict.offset is None
    assert words in verdict.reason
    assert authority.refused == 1 and authority.accepted == 0
    assert authority.last_refusal == verdict.reason  # kept for /diagnostics and the launcher's verdict


def test_an_offset_outside_the_workspace_is_clamped_onto_it() -> None:
    authority = CommandAuthority()
    verdict = authority.check(**command(desired_offset=[10.0, -10.0, 0.2]))
    assert verdict.accepted and verdict.clamped and "outside the workspace" in verdict.reason
    np.testing.assert_array_equal(verdict.offset, [0.5, -0.5, 0.2])


def test_x_d_prime_moves_no_faster_than_the_offset_speed_on_the_receivers_clock() -> None:
    authority = CommandAuthority(AuthorityBounds(max_offset_speed=1.0, max_offset_burst=0.05))
    assert authority.check(**command(now=NOW, desired_offset=[0.0, 0.0, 0.0])).accepted
    # 10 ms later (receiver's clock) a command asks for the box's corner: x_d' moves 1 cm toward it
    jump = authority.check(**command(now=NOW + 0.01, desired_offset=[10.0, 10.0, 10.0]))
    assert jump.accepted and jump.clamped and jump.rate_limited
    assert "outside the workspace" in jump.reason and "beyond 1 m/s" in jump.reason
    assert np.linalg.norm(jump.offset) == pytest.approx(0.01, abs=1e-6)
    np.testing.assert_allclose(jump.offset / np.linalg.norm(jump.offset), np.ones(3) / math.sqrt(3))
    # a flood of such commands, stamped as the sender likes, gains nothing: 100 in 10 ms move x_d' 1 cm more
    for k in range(100):
        last = authority.check(**command(stamp=NOW + 0.4, now=NOW + 0.01 + 1e-4 * (k + 1),
                                         desired_offset=[10.0, 10.0, 10.0]))
    assert np.linalg.norm(last.offset) == pytest.approx(0.02, abs=1e-6)


def test_a_burst_of_delayed_commands_within_the_burst_allowance_is_taken_whole() -> None:
    authority = CommandAuthority(AuthorityBounds(max_offset_speed=1.0, max_offset_burst=0.05))
    authority.check(**command(now=NOW, desired_offset=[0.0, 0.0, 0.0]))
    # the channel held commands for 40 ms and releases them together: the last one 3 cm on
    verdict = authority.check(**command(now=NOW + 0.04, desired_offset=[0.03, 0.0, 0.0]))
    assert verdict.accepted and not verdict.clamped and not verdict.rate_limited
    np.testing.assert_allclose(verdict.offset, [0.03, 0.0, 0.0])


def test_after_a_blackout_a_far_command_is_approached_at_the_bounded_speed() -> None:
    authority = CommandAuthority(AuthorityBounds(max_offset_speed=1.0, max_offset_burst=0.05))
    authority.check(**command(now=NOW, desired_offset=[0.0, 0.0, 0.0]))
    positions = [authority.check(**command(now=NOW + 5.0 + 0.01 * k, stamp=NOW + 4.9 + 0.01 * k,
                                           desired_offset=[0.3, 0.0, 0.0])).offset[0] for k in range(40)]
    assert positions[0] == pytest.approx(0.05)   # the burst allowance, not the 0.3 m jump
    assert np.all(np.diff(positions) <= 0.01 + 1e-6)  # then 1 m/s at 100 Hz
    assert positions[-1] == pytest.approx(0.3)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=3, max_size=3),
       st.floats(allow_nan=True, allow_infinity=True, width=64),
       st.floats(allow_nan=True, allow_infinity=True, width=64))
def test_no_input_yields_an_offset_outside_the_box_or_a_non_finite_one(offset, stamp, gain) -> None:
    authority = CommandAuthority()
    authority.check(**command(desired_offset=[0.0, 0.0, 0.0]))
    with np.errstate(all="raise"):  # an overflow inside the checks would raise here
        verdict = authority.check(**command(stamp=stamp, haptic_gain=gain, desired_offset=offset))
    if verdict.accepted:
        assert np.all(np.isfinite(verdict.offset))
        assert np.all(np.abs(verdict.offset) <= 0.5)


def test_bounds_are_validated() -> None:
    with pytest.raises(FicInputError):
        AuthorityBounds(offset_lower=(0.1, 0.0, 0.0), offset_upper=(0.0, 1.0, 1.0))
    with pytest.raises(FicInputError):
        AuthorityBounds(max_age=math.nan)


def test_a_second_publisher_latches_the_hold_and_says_so_once() -> None:
    guard = RobotStreamGuard()
    assert guard.publishers("/joint_states", ["/robot"]) == ""
    assert not guard.held
    reason = guard.publishers("/joint_states", ["/robot", "/intruder"])
    assert guard.held and "2 publishers on /joint_states" in reason and "/intruder" in reason
    assert guard.publishers("/joint_states", ["/robot", "/intruder"]) == ""  # one line, not one per check
    assert guard.publishers("/joint_states", ["/robot"]) == "" and guard.held  # latched


def test_joint_state_stamps_going_back_latch_the_hold_and_are_not_used() -> None:
    guard = RobotStreamGuard()
    assert guard.joint_state(10.000, 10.0) == (True, "")
    assert guard.joint_state(10.001, 10.0) == (True, "")
    assert guard.joint_state(10.001, 10.0) == (True, "")  # the same state again (lockstep republishes it)
    used, reason = guard.joint_state(9.5, 10.0)
    assert not used and guard.held and "went back by 0.501 s" in reason
    assert guard.joint_state(10.002, 10.0) == (True, "")  # the robot's own stream goes on, forward
    assert guard.joint_state(10.0015, 10.0) == (False, "")  # reason given once
    assert guard.skipped_states == 2


def test_a_second_matched_writer_latches_the_hold_once() -> None:
    guard = RobotStreamGuard()
    assert guard.matched("/joint_states", 1) == "" and not guard.held
    reason = guard.matched("/joint_states", 2)
    assert guard.held and reason == "2 publishers matched on /joint_states; one is the robot's"
    assert guard.matched("/joint_states", 3) == "" and guard.publishers("/joint_states", ["/a", "/b"]) == ""
    assert guard.matched("/joint_states", 1) == "" and guard.held  # latched


def test_a_joint_state_from_the_future_is_not_used() -> None:
    guard = RobotStreamGuard(future_tolerance=0.5)
    used, reason = guard.joint_state(NOW + 1.0e6, NOW)
    assert not used and guard.held and "future" in reason
    assert guard.joint_state(NOW, NOW) == (True, "")  # the future stamp did not become the reference


def test_bounds_from_the_replica_parameters_are_the_shipped_ones() -> None:
    """The node and the in-process runner build the authority from config/replica.yaml through one constructor."""
    from config_values import config_values

    values = config_values("replica.yaml")
    bounds = AuthorityBounds.from_parameters(AuthorityParameters.from_values(
        {name: values[name] for name in AUTHORITY_PARAMETERS}))
    half = values["offset_workspace"]
    assert bounds.offset_lower == (-half, -half, -half) and bounds.offset_upper == (half, half, half)
    assert (bounds.max_offset_speed, bounds.max_offset_burst, bounds.future_tolerance, bounds.max_age) == (
        values["max_offset_speed"], values["max_offset_burst"], values["command_future_tolerance"],
        values["max_command_age"])


@settings(max_examples=60, deadline=None, derandomize=True)
@given(steps=st.lists(st.one_of(st.floats(-2.0, 2.0), st.sampled_from([math.nan, math.inf, -math.inf, 0.5, 0.5001])),
                      min_size=1, max_size=12))
def test_every_joint_state_not_used_is_counted_once_and_no_used_one_is(steps: list[float]) -> None:
    """Stamps at NOW + step against an independent reading of the rule: a stamp is used when finite, at most
    future_tolerance ahead of the receiver's clock and not behind the last used one; every other one adds one to
    skipped_states, whichever rule refused it (non-finite, future, back in time)."""
    guard = RobotStreamGuard(future_tolerance=0.5)
    last, skipped = None, 0
    for step in steps:
        stamp = NOW + step
        expected = math.isfinite(stamp) and stamp - NOW <= 0.5 and (last is None or stamp >= last)
        used, _ = guard.joint_state(stamp, NOW)
        assert used == expected, (stamp, last)
        if used:
            last = stamp
        else:
            skipped += 1
        assert guard.skipped_states == skipped


@pytest.mark.parametrize("stamp", [math.nan, math.inf, -math.inf, NOW + 0.6])
def test_a_non_finite_or_future_stamp_adds_one_skipped_state(stamp: float) -> None:
    guard = RobotStreamGuard(future_tolerance=0.5)
    assert guard.joint_state(NOW, NOW) == (True, "")
    assert not guard.joint_state(stamp, NOW)[0]
    assert not guard.joint_state(stamp, NOW)[0]
    assert guard.skipped_states == 2


def test_a_jump_of_exactly_the_burst_is_taken_whole_and_one_a_hair_longer_is_rate_limited() -> None:
    """After a second's rest the bucket holds max_offset_burst (0.05 m): a command that far from the last is
    within it, taken as sent and not rate-limited; the next float above it is beyond it and clamped to the burst."""
    for length, limited in ((0.05, False), (float(np.nextafter(0.05, 1.0)), True)):
        authority = CommandAuthority(AuthorityBounds(max_offset_speed=1.0, max_offset_burst=0.05))
        authority.check(**command(now=NOW, desired_offset=[0.0, 0.0, 0.0]))
        verdict = authority.check(**command(now=NOW + 1.0, desired_offset=[0.0, 0.0, -length]))
        assert verdict.accepted and verdict.rate_limited == limited and not verdict.clamped, length
        if limited:
            assert np.linalg.norm(verdict.offset) <= 0.05 and "beyond 1 m/s" in verdict.reason
        else:
            np.testing.assert_array_equal(verdict.offset, [0.0, 0.0, -0.05])
