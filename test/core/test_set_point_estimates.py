"""The sampled set-point's estimates in figures (set_point.py's docstring): the slope of the last two samples from
their stamps, the acceleration as the low-pass (backward Euler, time constant tau) of the slope's difference
quotient, each clipped in norm with its direction kept; the hold moving along the slope; and the shrinking offset
given back along its own direction at its speed."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.errors import FicInputError
from fic_core.set_point import SampledSetPoint, ShrinkingOffset

RELATIVE = 1e-12


def test_the_slope_and_the_raw_acceleration_are_the_difference_quotients_of_the_stamps() -> None:
    """tau = 0: velocity (p_k - p_(k-1)) / (t_k - t_(k-1)) from the stamps, whatever the arrival times; the
    acceleration the difference of successive velocities over the stamps' interval."""
    hold = SampledSetPoint(acceleration_time_constant=0.0, blend_time=0.0, max_acceleration=100.0)
    hold.add(0.0, [0.0, 0.0, 0.0], received=5.0)
    hold.add(0.01, [0.001, -0.002, 0.0], received=5.013)           # 0.1, -0.2 m/s
    np.testing.assert_allclose(hold.velocity(5.013), [0.1, -0.2, 0.0], rtol=RELATIVE)
    np.testing.assert_allclose(hold.acceleration(5.013), [10.0, -20.0, 0.0], rtol=1e-9)   # from rest
    hold.add(0.03, [0.005, -0.002, 0.0], received=5.031)           # 0.2, 0 m/s over 0.02 s
    np.testing.assert_allclose(hold.velocity(5.031), [0.2, 0.0, 0.0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(hold.acceleration(5.031), [5.0, 10.0, 0.0], rtol=1e-9)
    # The hold moves on along the slope for the time since the sample came in (ours, not the stamp's).
    np.testing.assert_allclose(hold.position(5.041), [0.005 + 0.2 * 0.01, -0.002, 0.0], rtol=1e-9)


def test_the_acceleration_is_low_passed_with_its_time_constant() -> None:
    """tau = 0.05 s, samples 0.01 s apart: each new acceleration is a + (dv/dt - a) dt / (tau + dt)."""
    tau, dt = 0.05, 0.01
    hold = SampledSetPoint(acceleration_time_constant=tau, blend_time=0.0)
    positions = [0.0, 0.001, 0.003, 0.006]            # velocities 0.1, 0.2, 0.3 m/s: dv/dt = 10 m/s^2
    expected = 0.0
    velocity = 0.0
    for k, x in enumerate(positions):
        hold.add(k * dt, [x, 0.0, 0.0], received=k * dt)
        if k:
            new_velocity = (x - positions[k - 1]) / dt
            expected += ((new_velocity - velocity) / dt - expected) * dt / (tau + dt)
            velocity = new_velocity
            assert hold.acceleration(k * dt)[0] == pytest.approx(expected, rel=1e-9)
    assert 0.0 < expected < 10.0                      # lagging the true 10 m/s^2 by the filter, not at it


def test_the_estimates_are_clipped_in_norm_with_their_direction_kept() -> None:
    """A slope of 5 m/s along (0.6, 0.8, 0) is held at max_speed 1 m/s along it; the acceleration it implies at
    max_acceleration 10 m/s^2 along it too."""
    hold = SampledSetPoint(acceleration_time_constant=0.0, blend_time=0.0, max_speed=1.0, max_acceleration=10.0)
    hold.add(0.0, [0.0, 0.0, 0.0], received=0.0)
    hold.add(0.01, [0.03, 0.04, 0.0], received=0.01)
    velocity = hold.velocity(0.01)
    acceleration = hold.acceleration(0.01)
    assert np.linalg.norm(velocity) == pytest.approx(1.0, rel=RELATIVE)
    np.testing.assert_allclose(velocity, [0.6, 0.8, 0.0], rtol=1e-9)
    assert np.linalg.norm(acceleration) == pytest.approx(10.0, rel=RELATIVE)
    np.testing.assert_allclose(acceleration, [6.0, 8.0, 0.0], rtol=1e-9)
    np.testing.assert_allclose(hold.position(0.02), [0.03 + 0.006, 0.04 + 0.008, 0.0], rtol=1e-9)


def test_the_offset_shrinks_along_its_direction_at_its_speed_under_the_commanded_point() -> None:
    """A 0.5 m offset along (0, 0.6, 0.8) given back at 0.1 m/s: after each dt, commanded + the offset left, its
    norm 0.5 - 0.1 t along the same direction; gone after 5 s, and then inactive."""
    jump = ShrinkingOffset()
    jump.start([1.0, 0.3, 0.4], [1.0, 0.0, 0.0], speed=0.1)
    assert jump.active
    direction = np.array([0.0, 0.6, 0.8])
    for k in range(1, 50):
        commanded = np.array([0.01 * k, 0.0, 0.0])
        used = jump.apply(commanded, 0.1)
        np.testing.assert_allclose(used - commanded, (0.5 - 0.01 * k) * direction, rtol=1e-9, atol=1e-12)
    copy = jump.offset
    copy[:] = 7.0
    assert jump.offset[0] == 0.0 and jump.active
    np.testing.assert_allclose(jump.apply([0.0, 0.0, 0.0], 0.1), [0.0, 0.0, 0.0], atol=1e-12)
    assert not jump.active
    jump.start([0.0, 0.2, 0.0], [0.0, 0.0, 0.0], speed=0.1)
    jump.stop()
    assert not jump.active
    np.testing.assert_array_equal(jump.apply([1.0, 2.0, 3.0], 0.01), [1.0, 2.0, 3.0])
    with pytest.raises(FicInputError, match="in_use"):
        jump.start([np.nan, 0.0, 0.0], [0.0, 0.0, 0.0], speed=0.1)
    with pytest.raises(FicInputError, match="commanded"):
        jump.apply([0.0, np.inf, 0.0], 0.01)


def test_by_default_a_blackout_of_the_100_hz_stream_restarts_the_estimates_from_rest() -> None:
    """The default hold is made for a 100 Hz stream (the planner's, desired_pose.py): samples 0.2 s apart (a
    blackout of twenty samples) restart the velocity and acceleration from rest; 0.05 s apart (four lost) they
    are a slope like any other."""
    for gap, restarted in ((0.2, True), (0.05, False)):
        hold = SampledSetPoint()
        hold.add(0.0, [0.0, 0.0, 0.0], received=0.0)
        hold.add(0.01, [0.001, 0.0, 0.0], received=0.01)          # 0.1 m/s
        hold.add(0.01 + gap, [0.001 + 0.1 * gap, 0.0, 0.0], received=0.01 + gap)
        velocity = hold.velocity(0.01 + gap)
        if restarted:
            np.testing.assert_array_equal(velocity, [0.0, 0.0, 0.0])
            np.testing.assert_array_equal(hold.acceleration(0.01 + gap), [0.0, 0.0, 0.0])
        else:
            np.testing.assert_allclose(velocity, [0.1, 0.0, 0.0], rtol=1e-9)
