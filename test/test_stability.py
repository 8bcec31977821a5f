"""The sweep stability criterion (fic_teleop_experiments.stability) on systems whose stability is known.

The unstable cases are built from mathematics, not from the code under test: a mass-spring with negative damping
(its energy grows as exp(-c t / m)), and a mass under a spring acting on a DELAYED position,
m x'' + D x' + K x(t - tau) = 0, whose critical gain K_crit follows from the characteristic equation at s = j w:
w tau = atan(D / (m w)) and K_crit = w sqrt(m^2 w^2 + D^2). Half of K_crit must pass, 1.5 K_crit must fail.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_teleop_experiments.stability import (StabilityCriterion, StabilityInputError, assess_stability,
                                              oscillation_components)

DT = 0.001
MASS = 4.0


def simulate(stiffness: float, damping: float, *, duration: float = 20.0, delay: float = 0.0, x0: float = 0.02,
             reference=None, disturbance=None) -> tuple[np.ndarray, np.ndarray]:
    """Semi-implicit Euler of m x'' = K (r(t) - x(t - delay)) - D x' + d(t); returns (t, error r - x)."""
    steps = int(round(duration / DT))
    lag = int(round(delay / DT))
    t = np.arange(steps) * DT
    r = np.zeros(steps) if reference is None else reference(t)
    d = np.zeros(steps) if disturbance is None else disturbance(t)
    x = np.empty(steps)
    position, velocity = x0, 0.0
    for k in range(steps):
        x[k] = position
        seen = x[k - lag] if k >= lag else x0
        acceleration = (stiffness * (r[k] - seen) - damping * velocity + d[k]) / MASS
        velocity += acceleration * DT
        position += velocity * DT
    return t, np.column_stack([r - x, np.zeros(steps), np.zeros(steps)])


def critical_delay_gain(mass: float, damping: float, delay: float) -> float:
    """K_crit of m s^2 + D s + K exp(-s tau) = 0 (first crossing of the imaginary axis), by bisection on w."""
    low, high = 1e-6, math.pi / (2.0 * delay)  # w tau - atan(D/(m w)) goes from -pi/2 to > 0 on this interval
    for _ in range(200):
        mid = 0.5 * (low + high)
        if mid * delay - math.atan(damping / (mass * mid)) < 0.0:
            low = mid
        else:
            high = mid
    w = 0.5 * (low + high)
    return w * math.sqrt(mass ** 2 * w ** 2 + damping ** 2)


def test_negative_damping_is_flagged():
    t, error = simulate(200.0, -2.0)
    verdict = assess_stability(t, error)
    assert not verdict.stable
    assert verdict.energy_growth > 2.0
    assert any("growing" in reason for reason in verdict.reasons)


def test_damped_mass_spring_passes():
    t, error = simulate(200.0, 2.0 * 0.7 * math.sqrt(200.0 * MASS))
    verdict = assess_stability(t, error)
    assert verdict.stable, verdict.reasons
    assert verdict.max_error_last_half < 1e-3


def test_delayed_feedback_past_its_margin_is_flagged_and_within_it_passes():
    damping, delay = 40.0, 0.1
    critical = critical_delay_gain(MASS, damping, delay)
    assert 300.0 < critical < 600.0  # about 454 N/m for these numbers
    t, error = simulate(1.5 * critical, damping, delay=delay)
    unstable = assess_stability(t, error)
    assert not unstable.stable
    t, error = simulate(0.5 * critical, damping, delay=delay)
    stable = assess_stability(t, error)
    assert stable.stable, stable.reasons


def test_delayed_feedback_just_past_the_margin_is_flagged():
    damping, delay = 40.0, 0.1
    t, error = simulate(1.1 * critical_delay_gain(MASS, damping, delay), damping, delay=delay)
    assert not assess_stability(t, error).stable


def test_growing_oscillation_still_inside_the_error_bound_is_flagged():
    # From 1 mm, growing as exp(t/4): about 0.15 m at 20 s, so only the energy and oscillation tests can see it.
    t, error = simulate(200.0, -2.0, x0=0.001)
    verdict = assess_stability(t, error)
    assert verdict.max_error_last_half < StabilityCriterion().error_bound
    assert not verdict.stable
    assert any("growing" in reason for reason in verdict.reasons)


def test_delayed_feedback_just_inside_the_margin_is_not_flagged_as_growing():
    damping, delay = 40.0, 0.1
    critical = critical_delay_gain(MASS, damping, delay)
    t, error = simulate(0.9 * critical, damping, delay=delay, duration=30.0)
    verdict = assess_stability(t, error)
    assert verdict.energy_growth < 1.0  # it decays, slowly
    assert verdict.stable, verdict.reasons


def test_limit_cycle_is_a_sustained_oscillation():
    # A constant 1 cm, 3 Hz oscillation: energy does not grow, yet it never stops.
    t = np.arange(0.0, 20.0, DT)
    error = np.column_stack([0.01 * np.sin(2 * math.pi * 3.0 * t), np.zeros_like(t), np.zeros_like(t)])
    verdict = assess_stability(t, error)
    assert not verdict.stable
    assert verdict.energy_growth == pytest.approx(1.0, abs=0.2)
    assert verdict.oscillating_fraction == 1.0
    assert any("sustained" in reason for reason in verdict.reasons)


def test_tracking_a_circle_with_one_contact_in_the_last_quarter_passes():
    # A 0.2 Hz reference (the paper's circle) and a 2 s push in the last quarter (a contact transient).
    push = lambda t: np.where((t > 16.0) & (t < 18.0), 10.0, 0.0)  # noqa: E731
    circle = lambda t: 0.1 * np.sin(2 * math.pi * t / 5.0)  # noqa: E731
    t, error = simulate(200.0, 39.6, reference=circle, disturbance=push)
    verdict = assess_stability(t, error)
    assert verdict.stable, verdict.reasons
    assert verdict.max_error_last_half > 0.02  # the push shows in the error ...
    assert verdict.oscillating_fraction < 0.75  # ... but is not a sustained oscillation


def test_error_beyond_the_bound_is_flagged():
    t = np.arange(0.0, 10.0, DT)
    error = np.column_stack([np.where(t > 8.0, 0.3, 0.0), np.zeros_like(t), np.zeros_like(t)])
    verdict = assess_stability(t, error)
    assert not verdict.stable
    assert any("bound" in reason for reason in verdict.reasons)


def test_limit_violations_count_only_in_the_last_half():
    t = np.arange(0.0, 10.0, DT)
    error = np.zeros((t.size, 3))
    counter_time = np.arange(0.0, 10.0, 0.1)
    early = np.where(counter_time > 2.0, 5, 0)
    assert assess_stability(t, error, violation_time=counter_time, violation_count=early).stable
    late = np.where(counter_time > 7.0, 5, 0)
    verdict = assess_stability(t, error, violation_time=counter_time, violation_count=late)
    assert not verdict.stable and verdict.violations_last_half == 5


def test_slow_controller_samples_are_judged_like_fast_ones():
    # The same damped system sampled at 10 Hz (a 10 Hz controller's FicState) gives the same verdict.
    t, error = simulate(200.0, -2.0)
    slow = slice(None, None, 100)
    assert not assess_stability(t[slow], error[slow]).stable
    t, error = simulate(200.0, 40.0)
    assert assess_stability(t[slow], error[slow]).stable


def test_oscillation_components_remove_slow_motion_and_keep_fast():
    t = np.arange(0.0, 10.0, DT)
    slow = 0.05 * np.sin(2 * math.pi * 0.2 * t)
    fast = 0.01 * np.sin(2 * math.pi * 3.0 * t)
    grid, oscillation, energy = oscillation_components(t, (slow + fast)[:, None])
    middle = (grid > 2.0) & (grid < 8.0)
    amplitude = np.max(np.abs(oscillation[middle, 0]))
    # A W = 0.5 s moving average passes sin(pi f W)/(pi f W) of a sinusoid: +0.98 of the 0.2 Hz one, -0.21 of the
    # 3 Hz one (1.5 periods in the window), so e_osc holds 1.6 % of the slow one and 121 % of the fast one.
    gain = lambda f: 1.0 - math.sin(math.pi * f * 0.5) / (math.pi * f * 0.5)  # noqa: E731
    expected = 0.01 * gain(3.0)
    assert abs(amplitude - expected) < 0.05 * gain(0.2) + 2e-4
    _, slow_only, _ = oscillation_components(t, slow[:, None])
    assert np.max(np.abs(slow_only[middle, 0])) == pytest.approx(0.05 * gain(0.2), rel=0.05)
    # Energy of the oscillation: 1/2 K e^2 + 1/2 m e'^2, at least the spring's share at its peaks.
    assert np.max(energy[middle]) > 0.5 * 200.0 * (0.95 * expected) ** 2


def test_bad_input_is_refused():
    with pytest.raises(StabilityInputError):
        assess_stability([0.0, 1.0], np.zeros((2, 3)))
    with pytest.raises(StabilityInputError):
        assess_stability(np.arange(10.0), np.full((10, 3), np.nan))
    with pytest.raises(StabilityInputError):
        assess_stability(np.arange(10.0)[::-1], np.zeros((10, 3)))
    with pytest.raises(StabilityInputError):
        assess_stability(np.arange(10.0), np.zeros((9, 3)))


def test_verdict_is_json_ready():
    import json

    t, error = simulate(200.0, -2.0, duration=8.0)
    payload = json.dumps(assess_stability(t, error, criterion=StabilityCriterion(error_bound=0.1)).as_dict())
    assert '"stable": false' in payload


def test_oscillation_only_in_contact_is_not_sustained_but_in_free_motion_it_is():
    # A 1 cm, 3 Hz oscillation while the F/T reads 20 N (chatter against an obstacle) during the middle of the last
    # half, free motion otherwise: test 4 judges the free-motion windows only, so it passes; the same oscillation in
    # free motion (force 0) is flagged.
    t = np.arange(0.0, 20.0, DT)
    in_contact = (t > 9.0) & (t < 18.5)
    error = np.column_stack([np.where(in_contact, 0.01 * np.sin(2 * math.pi * 3.0 * t), 0.0), np.zeros_like(t),
                             np.zeros_like(t)])
    force = np.column_stack([np.where(in_contact, 20.0, 0.0), np.zeros_like(t), np.zeros_like(t)])
    contact = assess_stability(t, error, force_time=t, force=force)
    assert contact.stable, contact.reasons
    assert 0 < contact.free_windows_last_half < contact.windows_last_half
    everywhere = np.column_stack([0.01 * np.sin(2 * math.pi * 3.0 * t), np.zeros_like(t), np.zeros_like(t)])
    free = assess_stability(t, everywhere, force_time=t, force=np.zeros((t.size, 3)))
    assert not free.stable and any("free-motion" not in r and "sustained" in r for r in free.reasons)


def test_an_impact_burst_in_the_last_quarter_of_a_contact_task_is_not_growth():
    # Free motion with a small 2 mm wobble, then 1.8 s of 1.5 cm, 3 Hz chatter against an obstacle (F/T 20 N) in the
    # last quarter: with the force, test 3 compares free-motion windows and passes; an oscillation that grows in
    # free motion is still flagged.
    t = np.arange(0.0, 20.0, DT)
    burst = (t > 15.5) & (t < 17.3)
    error = 0.002 * np.sin(2 * math.pi * 3.0 * t) + np.where(burst, 0.015 * np.sin(2 * math.pi * 3.0 * t), 0.0)
    force = np.column_stack([np.where(burst, 20.0, 0.0), np.zeros_like(t), np.zeros_like(t)])
    verdict = assess_stability(t, np.column_stack([error, 0 * t, 0 * t]), force_time=t, force=force)
    assert verdict.stable and verdict.growth_in_free_motion, verdict.reasons
    growing = 0.002 * np.exp(0.25 * (t - 10.0)) * np.sin(2 * math.pi * 3.0 * t)
    verdict = assess_stability(t, np.column_stack([growing, 0 * t, 0 * t]), force_time=t, force=0 * force)
    assert not verdict.stable and any("growing in free motion" in r for r in verdict.reasons)
