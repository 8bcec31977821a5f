"""fic_core.set_point: the first-order hold of sampled set-points and the shrinking offset that takes out jumps."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_core.errors import FicInputError
from fic_core.set_point import SampledSetPoint, ShrinkingOffset

PERIOD = 0.01  # 100 Hz samples, the master's network rate and the planner's publish rate
DT = 0.001     # the control loop


def test_a_ramp_is_reproduced_between_samples_despite_arrival_jitter() -> None:
    """Samples of x(t) = x0 + v t stamped at the sender, arriving 5 +- 3 ms later: at 1 kHz the hold gives
    x(now - 5 ms) up to the jitter's share (v * 3 ms), never the 10 ms staircase."""
    rng = np.random.default_rng(3)
    velocity = np.array([0.1, -0.2, 0.05])
    hold = SampledSetPoint(max_extrapolation=0.05)
    errors = []
    stamp, latency = 0.0, 0.005
    arrival = stamp + latency
    next_stamp = PERIOD
    for tick in range(1, 3000):
        now = tick * DT
        while arrival <= now:
            hold.add(stamp, velocity * stamp, arrival)
            stamp = next_stamp
            next_stamp += PERIOD
            arrival = stamp + latency + rng.uniform(-0.003, 0.003)
        if tick > 100:
            errors.append(np.linalg.norm(hold.position(now) - velocity * (now - latency)))
            np.testing.assert_allclose(hold.velocity(now), velocity, atol=1e-9)
    staircase = np.linalg.norm(velocity) * PERIOD
    assert max(errors) < np.linalg.norm(velocity) * 0.0031 < staircase / 3


def test_the_acceleration_estimate_converges_on_a_parabola() -> None:
    acceleration = np.array([0.5, -0.3, 0.2])
    hold = SampledSetPoint(acceleration_time_constant=0.05)
    for k in range(100):
        t = k * PERIOD
        hold.add(t, 0.5 * acceleration * t * t, t)
    np.testing.assert_allclose(hold.acceleration(0.99), acceleration, rtol=1e-6)


def test_the_acceleration_estimate_of_a_circle_lags_by_its_filter() -> None:
    """The paper's circle (r = 0.1 m, 5 s): centripetal 0.158 m/s^2, estimated within 10 % of its magnitude with
    a 0.05 s filter (a 3.6 deg phase lag)."""
    rate = 2.0 * math.pi / 5.0
    hold = SampledSetPoint(acceleration_time_constant=0.05)
    worst = 0.0
    for k in range(600):
        t = k * PERIOD
        hold.add(t, 0.1 * np.array([math.cos(rate * t), math.sin(rate * t), 0.0]), t)
        if t > 1.0:
            truth = -0.1 * rate ** 2 * np.array([math.cos(rate * t), math.sin(rate * t), 0.0])
            worst = max(worst, np.linalg.norm(hold.acceleration(t) - truth) / np.linalg.norm(truth))
    assert worst < 0.1


def test_the_hold_stops_after_max_extrapolation_and_restarts_after_a_gap() -> None:
    hold = SampledSetPoint(max_extrapolation=0.02, max_sample_gap=0.1, blend_time=0.0)
    hold.add(0.0, [0.0, 0.0, 0.0], 0.0)
    hold.add(0.01, [0.001, 0.0, 0.0], 0.01)  # 0.1 m/s
    np.testing.assert_allclose(hold.position(0.02), [0.002, 0.0, 0.0])
    np.testing.assert_allclose(hold.position(1.0), [0.003, 0.0, 0.0])  # capped at 0.02 s: a lost stream stops
    assert not hold.velocity(1.0).any() and not hold.acceleration(1.0).any()
    hold.add(1.0, [0.5, 0.0, 0.0], 1.0)  # after a blackout: no slope across the gap
    assert not hold.velocity(1.0).any()
    np.testing.assert_allclose(hold.position(1.01), [0.5, 0.0, 0.0])


def test_a_repeated_or_older_stamp_changes_no_slope() -> None:
    hold = SampledSetPoint()
    hold.add(0.0, [0.0, 0.0, 0.0], 0.0)
    hold.add(0.01, [0.001, 0.0, 0.0], 0.01)
    hold.add(0.005, [0.3, 0.0, 0.0], 0.012)
    np.testing.assert_allclose(hold.velocity(0.012), [0.1, 0.0, 0.0])


def test_a_burst_after_a_stalled_sender_makes_no_jump() -> None:
    """A sender that stalled sends three samples 0.1 ms apart with a little noise: no huge velocity, no jump of
    the extrapolated set-point, and the estimates stay within their bounds."""
    hold = SampledSetPoint(max_speed=1.0, max_acceleration=10.0)
    for k in range(10):
        hold.add(k * PERIOD, [0.001 * k, 0.0, 0.0], k * PERIOD)
    t = 0.09
    for k, noise in enumerate((0.0, 0.0005, -0.0005)):
        hold.add(t + 1e-4 * k, [0.01 + noise, 0.0, 0.0], 0.2)
    assert np.linalg.norm(hold.velocity(0.2)) <= 1.0
    np.testing.assert_allclose(hold.velocity(0.2), [0.1, 0.0, 0.0])  # the slope of the regular samples
    assert np.linalg.norm(hold.position(0.25) - [0.0095, 0.0, 0.0]) <= 1.0 * 0.05
    hold.add(0.1, [0.5, 0.0, 0.0], 0.21)  # a wild sample: clipped estimates
    assert np.linalg.norm(hold.velocity(0.21)) <= 1.0 + 1e-12
    assert np.linalg.norm(hold.acceleration(0.21)) <= 10.0 + 1e-12


def test_a_sample_after_a_gap_is_blended_in_not_stepped() -> None:
    """The stream pauses for 80 ms while the set-point moves on at 0.1 m/s: the next sample lands 7 mm from where
    the hold stopped; x_d moves there continuously over blend_time, then follows the samples."""
    hold = SampledSetPoint(max_extrapolation=0.05, blend_time=0.05)
    for k in range(5):
        hold.add(k * PERIOD, [0.1 * k * PERIOD, 0.0, 0.0], k * PERIOD)
    stopped = hold.position(0.12)[0]
    assert stopped == pytest.approx(0.004 + 0.1 * 0.05)  # the hold stopped after max_extrapolation
    hold.add(0.12, [0.012, 0.0, 0.0], 0.12)
    assert hold.position(0.12)[0] == pytest.approx(stopped, abs=1e-12)  # no step
    track = [hold.position(0.12 + k * DT)[0] for k in range(60)]
    biggest_step = max(abs(b - a) for a, b in zip(track, track[1:]))
    assert biggest_step <= (0.012 - stopped) / 0.05 * DT + 0.1 * DT + 1e-12
    assert hold.position(0.17)[0] == pytest.approx(0.012 + 0.1 * 0.05)  # blended in, following the samples


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_samples_are_refused(bad: float) -> None:
    hold = SampledSetPoint()
    with pytest.raises(FicInputError, match="position"):
        hold.add(0.0, [0.0, bad, 0.0], 0.0)
    with pytest.raises(FicInputError, match="stamp"):
        hold.add(bad, [0.0, 0.0, 0.0], 0.0)
    with pytest.raises(FicInputError, match="no sample"):
        hold.position(0.0)
    with pytest.raises(FicInputError, match="acceleration_time_constant"):
        SampledSetPoint(acceleration_time_constant=bad)


def test_a_jump_is_given_back_at_the_speed_even_under_a_faster_moving_target() -> None:
    """The planner's first pose 0.28 m from the start, the circle moving at 0.126 m/s, given back at 0.1 m/s: the
    set-point in use joins the circle after exactly 0.28 / 0.1 s, and never moves by more than the circle's step
    plus the give-back step in a tick (no jump)."""
    rate = 2.0 * math.pi / 5.0

    def circle(t: float) -> np.ndarray:
        return np.array([0.45, 0.0, 0.35]) + 0.1 * np.array([math.cos(rate * t), math.sin(rate * t), 0.0])

    start = circle(0.0) + np.array([-0.24, 0.0, 0.144])  # |jump| = 0.28 m
    jump = ShrinkingOffset()
    jump.start(start, circle(0.0), speed=0.1)
    previous = start
    joined = None
    for tick in range(1, 4000):
        t = tick * DT
        in_use = jump.apply(circle(t), DT)
        step = np.linalg.norm(in_use - previous)
        assert step <= np.linalg.norm(circle(t) - circle(t - DT)) + 0.1 * DT + 1e-12
        previous = in_use
        if joined is None and not jump.active:
            joined = t
            np.testing.assert_allclose(in_use, circle(t))
    assert joined == pytest.approx(0.28 / 0.1, abs=2 * DT)


def test_a_stopped_jump_is_forgotten() -> None:
    jump = ShrinkingOffset()
    jump.start([0.1, 0.0, 0.0], [0.0, 0.0, 0.0], speed=0.1)
    assert jump.active
    jump.stop()
    np.testing.assert_allclose(jump.apply([1.0, 2.0, 3.0], DT), [1.0, 2.0, 3.0])
    with pytest.raises(FicInputError, match="speed"):
        jump.start([0.0] * 3, [0.0] * 3, speed=0.0)


@pytest.mark.parametrize("changes, words", [
    ({"dimension": 0}, "dimension"), ({"dimension": True}, "dimension"), ({"dimension": 3.0}, "dimension"),
    ({"max_extrapolation": -0.01}, "max_extrapolation"), ({"max_sample_gap": 0.0}, "max_sample_gap"),
    ({"min_sample_interval": -1e-3}, "min_sample_interval"), ({"max_speed": 0.0}, "max_speed"),
    ({"max_acceleration": 0.0}, "max_acceleration"), ({"blend_time": -0.05}, "blend_time"),
    ({"acceleration_time_constant": -0.05}, "acceleration_time_constant"),
])
def test_each_parameter_of_the_hold_is_checked_with_its_name(changes, words) -> None:
    with pytest.raises(FicInputError, match=words):
        SampledSetPoint(**changes)


def test_the_slopes_interval_and_the_gap_are_closed_at_their_ends() -> None:
    """A sample exactly min_sample_interval after the last one measures a slope; exactly max_sample_gap after it is
    not yet a gap (the slope across it is measured); past max_sample_gap the estimates restart from rest. Times on
    binary fractions, so that each difference is exact."""
    hold = SampledSetPoint(min_sample_interval=0.25, max_sample_gap=0.5, max_extrapolation=1.0, blend_time=0.0,
                           acceleration_time_constant=0.0, max_speed=10.0, max_acceleration=100.0)
    hold.add(0.0, [0.0, 0.0, 0.0], 0.0)
    hold.add(0.25, [0.25, 0.0, 0.0], 0.25)                       # 1 m/s
    np.testing.assert_array_equal(hold.velocity(0.25), [1.0, 0.0, 0.0])
    np.testing.assert_array_equal(hold.acceleration(0.25), [4.0, 0.0, 0.0])   # raw: (1 - 0) / 0.25
    hold.add(0.75, [0.25, 0.5, 0.0], 0.75)                       # 0.5 s on: the gap's end, still a slope
    np.testing.assert_array_equal(hold.velocity(0.75), [0.0, 1.0, 0.0])
    hold.add(1.25 + 2 ** -20, [0.0, 0.0, 0.0], 1.25)             # a hair past the gap: from rest
    np.testing.assert_array_equal(hold.velocity(1.25), 0.0)
    np.testing.assert_array_equal(hold.acceleration(1.25), 0.0)


def test_the_velocity_holds_for_exactly_max_extrapolation_and_never_extrapolates_backwards() -> None:
    hold = SampledSetPoint(max_extrapolation=0.25, max_sample_gap=1.0, blend_time=0.0)
    hold.add(0.0, [0.0, 0.0, 0.0], 0.0)
    hold.add(0.5, [0.5, 0.0, 0.0], 0.5)                          # 1 m/s
    np.testing.assert_array_equal(hold.velocity(0.75), [1.0, 0.0, 0.0])
    np.testing.assert_array_equal(hold.position(0.75), [0.75, 0.0, 0.0])
    assert not hold.velocity(0.75 + 2 ** -20).any() and not hold.acceleration(0.75 + 2 ** -20).any()
    np.testing.assert_array_equal(hold.position(0.25), [0.5, 0.0, 0.0])   # a clock behind the sample: the sample


def test_one_stamp_far_ahead_does_not_freeze_the_estimates() -> None:
    """A stamp 100 s ahead restarts the estimates and becomes the slope's reference; the sender's next normal
    stamps, 100 s behind it, restart them once more, and then the slope is measured again."""
    hold = SampledSetPoint(blend_time=0.0, acceleration_time_constant=0.0)
    for k in range(3):
        hold.add(k * PERIOD, [0.001 * k, 0.0, 0.0], k * PERIOD)
    hold.add(100.0, [0.0, 0.0, 0.0], 0.025)
    assert not hold.velocity(0.025).any()
    hold.add(0.03, [0.003, 0.0, 0.0], 0.03)
    assert not hold.velocity(0.03).any()
    hold.add(0.04, [0.004, 0.0, 0.0], 0.04)
    np.testing.assert_allclose(hold.velocity(0.04), [0.1, 0.0, 0.0])


def test_a_jump_beyond_float_range_is_a_step_from_rest_never_inf_or_nan() -> None:
    """Moving at 0.1 m/s, then a sample at 1e308 m and one at -1e308 m: their difference quotient is not a float,
    so the estimates restart from rest rather than keep the last slope; the hold's output stays finite."""
    hold = SampledSetPoint()
    hold.add(0.0, [0.0, 0.0, 0.0], 0.0)
    hold.add(0.01, [0.001, 0.0, 0.0], 0.01)
    hold.add(0.02, [1e308, 0.0, 0.0], 0.02)
    hold.add(0.03, [-1e308, 0.0, 0.0], 0.03)
    assert not hold.velocity(0.03).any() and not hold.acceleration(0.03).any()
    assert np.all(np.isfinite([hold.position(0.03 + k * DT) for k in range(60)]))
    np.testing.assert_array_equal(hold.position(0.09), [-1e308, 0.0, 0.0])


def test_reset_forgets_every_sample() -> None:
    hold = SampledSetPoint(dimension=6)
    hold.add(0.0, np.ones(6), 0.0)
    assert hold.has_sample
    hold.reset()
    assert not hold.has_sample and not hold.velocity(0.0).any()
    with pytest.raises(FicInputError, match="no sample"):
        hold.position(0.0)


def test_an_offset_exactly_one_step_long_is_given_back_whole_and_none_is_not_active() -> None:
    jump = ShrinkingOffset()
    jump.start([0.5, 0.0, 0.0], [0.5, 0.0, 0.0], speed=0.1)
    assert not jump.active                                        # no difference: nothing to give back
    jump.start([0.25, 0.0, 0.0], [0.0, 0.0, 0.0], speed=1.0)      # 0.25 m at 1 m/s: one 0.25 s step
    np.testing.assert_array_equal(jump.apply([0.0, 0.0, 0.0], 0.125), [0.125, 0.0, 0.0])
    np.testing.assert_array_equal(jump.apply([0.0, 0.0, 0.0], 0.125), [0.0, 0.0, 0.0])
    assert not jump.active
    jump.offset[0] = 5.0                                          # a copy
    np.testing.assert_array_equal(jump.offset, 0.0)


def test_a_stamp_exactly_max_sample_gap_behind_is_an_older_stamp_not_a_restart() -> None:
    """Only a stamp further than max_sample_gap off the last one restarts the estimates and becomes the slope's
    reference; one exactly that far behind is an older stamp: it moves the hold but not the slope's reference."""
    hold = SampledSetPoint(min_sample_interval=2 ** -6, max_sample_gap=0.5, max_extrapolation=1.0, blend_time=0.0,
                           max_speed=10.0)
    hold.add(0.0, [0.0, 0.0, 0.0], 0.0)
    hold.add(0.25, [0.25, 0.0, 0.0], 0.25)                         # 1 m/s
    hold.add(-0.25, [5.0, 0.0, 0.0], 0.26)                         # exactly the gap behind
    np.testing.assert_array_equal(hold.velocity(0.26), [1.0, 0.0, 0.0])   # no restart
    hold.add(0.5, [0.75, 0.0, 0.0], 0.5)                           # the slope from the sample at 0.25
    np.testing.assert_array_equal(hold.velocity(0.5), [2.0, 0.0, 0.0])
