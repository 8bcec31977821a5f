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


@pytest.mark.parametrize("field, inside, outside", [
    ("haptic_gain", 1.0, float(np.nextafter(1.0, 2.0))),
    ("haptic_gain", 0.0, -5e-324),
    ("workspace_scale", 100.0, float(np.nextafter(100.0, 200.0))),
    ("workspace_scale", 0.01, float(np.nextafter(0.01, 0.0))),
    ("velocity_gain", 100.0, float(np.nextafter(100.0, 200.0))),
    ("velocity_gain", 0.0, -5e-324),
    ("handle_position", [10.0, -10.0, 0.0], [0.0, float(np.nextafter(-10.0, -20.0)), 0.0]),
])
def test_the_ranges_ends_are_accepted_and_the_next_float_past_them_refused(field, inside, outside) -> None:
    """K_H in [0, 1] (Eq. 3), s_M and k_v within the master's own rows, |x_M| at most 10 m per axis: closed ranges,
    so their ends are a valid command and the next float beyond them is not."""
    authority = CommandAuthority()
    assert authority.check(**command(**{field: inside})).accepted
    verdict = authority.check(**command(**{field: outside}))
    assert not verdict.accepted and (authority.accepted, authority.refused) == (1, 1)


def test_the_stamp_window_is_closed_at_both_ends() -> None:
    """A stamp exactly future_tolerance ahead or exactly max_age behind the receiver's clock is inside the window
    (the channel's delay may fill max_age); the next float past either end is refused, with the figures said."""
    bounds = AuthorityBounds(future_tolerance=0.5, max_age=3.0)
    for stamp in (NOW + 0.5, NOW - 3.0):
        assert CommandAuthority(bounds).check(**command(stamp=stamp)).accepted, stamp
    ahead = CommandAuthority(bounds).check(**command(stamp=float(np.nextafter(NOW + 0.5, np.inf))))
    assert not ahead.accepted and ahead.reason == "stamped 0.5 s in the receiver's future (tolerance 0.5 s)"
    behind = CommandAuthority(bounds).check(**command(stamp=NOW - 4.0))
    assert not behind.accepted and behind.reason == "stamped 4 s in the past (at most 3 s)"
    assert not CommandAuthority(bounds).check(**command(stamp=float(np.nextafter(NOW - 3.0, 0.0)))).accepted


def test_x_m_and_x_d_prime_must_be_3_vectors() -> None:
    for field in ("handle_position", "desired_offset"):
        verdict = CommandAuthority().check(**command(**{field: [0.0, 0.0]}))
        assert not verdict.accepted and verdict.reason == "x_M and x_d' must be 3-vectors"


def test_the_counters_count_each_verdict_once() -> None:
    """accepted, refused, clamped (outside the box) and rate_limited, over a clean, an outside, a fast and a
    refused command."""
    authority = CommandAuthority(AuthorityBounds(max_offset_speed=1.0, max_offset_burst=0.05))
    authority.check(**command(now=NOW, desired_offset=[0.0, 0.0, 0.0]))                  # clean
    authority.check(**command(now=NOW + 1.0, desired_offset=[0.0, 0.0, 0.04]))           # within the burst
    authority.check(**command(now=NOW + 2.0, desired_offset=[0.0, 0.0, 0.9]))            # outside and too far
    authority.check(**command(now=NOW + 2.0, mode=3))                                    # refused
    assert (authority.accepted, authority.refused, authority.clamped, authority.rate_limited) == (3, 1, 1, 1)


def test_a_refused_command_neither_moves_x_d_prime_nor_fills_the_bucket() -> None:
    """Only accepted commands set the last x_d' and its receipt time: a malformed command between two good ones
    does not change what the second may move (the bucket is filled from the first's receipt)."""
    authority = CommandAuthority(AuthorityBounds(max_offset_speed=1.0, max_offset_burst=0.05))
    authority.check(**command(now=NOW, desired_offset=[0.0, 0.0, 0.0]))
    assert not authority.check(**command(now=NOW + 0.01, mode=5, desired_offset=[0.3, 0.0, 0.0])).accepted
    verdict = authority.check(**command(now=NOW + 0.02, desired_offset=[0.3, 0.0, 0.0]))
    np.testing.assert_allclose(verdict.offset, [0.02, 0.0, 0.0], atol=1e-6)   # 20 ms at 1 m/s from x_d' = 0
    # (atol: NOW's float spacing, 2.4e-7 s)


def test_reset_forgets_the_last_command_and_its_bucket() -> None:
    """After ``reset`` (the replica's resume) the next command is only clamped onto the box, as a first one is."""
    authority = CommandAuthority(AuthorityBounds(max_offset_speed=1.0, max_offset_burst=0.05))
    authority.check(**command(now=NOW, desired_offset=[0.0, 0.0, 0.0]))
    authority.reset()
    verdict = authority.check(**command(now=NOW + 0.001, desired_offset=[0.3, -0.2, 0.1]))
    assert verdict.accepted and not verdict.rate_limited
    np.testing.assert_array_equal(verdict.offset, [0.3, -0.2, 0.1])
    # and the bucket starts empty: 1 ms later, 1 mm more at most
    later = authority.check(**command(now=NOW + 0.002, desired_offset=[0.0, -0.2, 0.1]))
    np.testing.assert_allclose(later.offset, [0.299, -0.2, 0.1], atol=1e-6)


def test_a_receiver_clock_that_goes_back_gives_x_d_prime_no_room() -> None:
    """The bucket fills with elapsed time on the receiver's clock, never less than none: with an empty bucket, a
    command received 'before' the last one leaves x_d' where it stands rather than moving it backwards."""
    for authority in (CommandAuthority(AuthorityBounds(max_offset_speed=1.0, max_offset_burst=0.05)),):
        authority.check(**command(now=NOW, desired_offset=[0.0, 0.0, 0.0]))
        verdict = authority.check(**command(now=NOW - 1.0, stamp=NOW - 1.2, desired_offset=[0.01, 0.0, 0.0]))
        assert verdict.accepted and verdict.rate_limited
        np.testing.assert_array_equal(verdict.offset, [0.0, 0.0, 0.0])


@settings(max_examples=80, deadline=None, derandomize=True)
@given(st.lists(st.tuples(st.sampled_from([0.0, 0.001, 0.01, 0.1, 1.0]),
                          st.one_of(st.sampled_from([(0.0, 0.0, 0.0), (0.001, 0.0, 0.0), (0.4, 0.4, -0.4)]),
                                    st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3))),
                min_size=1, max_size=40))
def test_x_d_prime_never_outruns_its_token_bucket(steps) -> None:
    """Over any run of accepted commands, x_d' stays in the box and moves between two of them by at most the
    burst plus max_offset_speed times the time between them; each step is toward the command asked."""
    speed, burst = 0.5, 0.02
    authority = CommandAuthority(AuthorityBounds(max_offset_speed=speed, max_offset_burst=burst))
    now = NOW
    offsets, times = [authority.check(**command(now=now, desired_offset=[0.0, 0.0, 0.0])).offset], [now]
    for elapsed, target in steps:
        now += elapsed
        verdict = authority.check(**command(now=now, stamp=now, desired_offset=target))
        assert verdict.accepted and np.all(np.abs(verdict.offset) <= 0.5)
        step = verdict.offset - offsets[-1]
        asked = np.clip(target, -0.5, 0.5) - offsets[-1]
        assert np.linalg.norm(step) <= np.linalg.norm(asked) + 1e-12
        assert np.linalg.norm(np.cross(step, asked)) <= 1e-9   # along the way to the command
        offsets.append(verdict.offset)
        times.append(now)
    travelled = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(offsets, axis=0), axis=1))])
    elapsed = np.asarray(times) - NOW
    # every window [first, last]: travelled[last] - travelled[first] <= burst + speed (t_last - t_first)
    budget = travelled - speed * elapsed
    assert np.all(np.triu(budget[None, :] - budget[:, None]) <= burst + 1e-6)


@pytest.mark.parametrize("changes, words", [
    ({"max_offset_speed": 0.0}, "max_offset_speed"),
    ({"max_offset_burst": -0.01}, "max_offset_burst"),
    ({"future_tolerance": -0.1}, "future_tolerance"),
    ({"max_age": 0.0}, "max_age"),
    ({"haptic_gain": (1.0, 0.0)}, "haptic_gain range"),
    ({"workspace_scale": (math.nan, 1.0)}, "workspace_scale range"),
    ({"velocity_gain": (0.0, math.inf)}, "velocity_gain range"),
    ({"max_handle_position": 0.0}, "max_handle_position"),
    ({"offset_lower": (0.0, 0.0)}, "offset_lower"),
    ({"offset_upper": (0.5, 0.5, -0.5)}, "below offset_upper"),
])
def test_each_bound_is_checked_with_its_name(changes, words) -> None:
    with pytest.raises(FicInputError, match=words):
        AuthorityBounds(**changes)


def test_the_bounds_edges_that_make_sense_are_accepted() -> None:
    """No burst (x_d' moves by the speed alone), no clock-skew allowance, a point range: valid bounds."""
    bounds = AuthorityBounds(max_offset_burst=0.0, future_tolerance=0.0, haptic_gain=(0.5, 0.5))
    assert CommandAuthority(bounds).check(**command(stamp=NOW)).accepted


def test_a_joint_state_stamped_exactly_at_the_tolerance_is_used_and_a_negative_tolerance_refused() -> None:
    guard = RobotStreamGuard(future_tolerance=0.5)
    assert guard.joint_state(NOW + 0.5, NOW) == (True, "")
    assert not guard.held and guard.skipped_states == 0
    with pytest.raises(FicInputError, match="future_tolerance"):
        RobotStreamGuard(future_tolerance=-0.5)
    assert RobotStreamGuard().publishers("/joint_states", []) == ""   # no writer yet is no breach
