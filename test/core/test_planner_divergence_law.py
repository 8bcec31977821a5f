"""The planner's phases on paper Eq. 5's lines, step by step. D: a = sign(x~_t) min(w_n^2 |x~_t|, a_max) - mu v,
mu = 0.01 w_n (the viscous term is small, a hundredth of w_n, so a run's figures do not show its sign; the law's
acceleration does). C: a = 2 A_max / x~_T0 (x~_t - x~_T0 / 2) - mu v, A_max the D acceleration at x~_T0."""
from __future__ import annotations

import numpy as np

from fic_core.attractor import Phase
from fic_core.planner import VISCOSITY_RATIO, HarmonicPlanner


def test_a_chased_target_keeps_the_planner_in_d_with_the_viscous_term_braking() -> None:
    """A target that runs away at 0.5 m/s: |x~_t| grows while the planner is slower than it, so the axis stays in D
    and its velocity is not zero. Each D step's acceleration ((v_k - v_{k-1}) / dt) is Eq. 5's D line, the viscous
    term opposing the velocity (a term with the other sign would add 2 mu v)."""
    natural_frequency, dt, target_speed = 10.0, 0.002, 0.5
    planner = HarmonicPlanner(natural_frequency, max_velocity=2.0, dimension=1)
    viscosity = VISCOSITY_RATIO * natural_frequency
    assert planner.viscosity == viscosity
    checked = 0
    for step in range(1, 200):
        target = np.array([0.02 + target_speed * step * dt])
        error = target - planner.position
        velocity = planner.velocity
        planner.step(target, dt)
        if planner.phase[0] != int(Phase.DIVERGENCE):
            continue
        pull = np.sign(error) * np.minimum(natural_frequency ** 2 * np.abs(error), planner.max_acceleration)
        expected = np.clip(pull - viscosity * velocity, -planner.max_acceleration, planner.max_acceleration)
        np.testing.assert_allclose(planner.acceleration, expected, rtol=1e-9, atol=1e-12)
        checked += abs(velocity[0]) > 0.05   # the viscous term is then at least 0.005 m/s^2
    assert checked >= 20


def test_a_move_longer_than_a_metre_converges_on_eq5s_c_line_with_a_max_of_its_d_phase() -> None:
    """A fixed target 2 m away: |x~_t| decreases from the first step, so the axis enters C with x~_T0 = 2 m and
    A_max = min(w_n^2 |x~_T0|, a_max), the D acceleration there. Each C step's acceleration is Eq. 5's C line,
    2 A_max / x~_T0 (x~_t - x~_T0 / 2) - mu v (within a_max, while the velocity is under v_d)."""
    natural_frequency, dt = 1.0, 0.01
    planner = HarmonicPlanner(natural_frequency, max_velocity=2.0, dimension=1)
    viscosity = VISCOSITY_RATIO * natural_frequency
    target = np.array([2.0])
    latched = None
    checked = 0
    for _ in range(400):
        error = target - planner.position
        velocity = planner.velocity
        planner.step(target, dt)
        if planner.phase[0] != int(Phase.CONVERGENCE):
            if latched is not None:
                break   # the first C phase is over
            continue
        if latched is None:
            latched = error   # x~_T0: the displacement where C begins
        a_max = planner.max_acceleration
        largest = np.minimum(natural_frequency ** 2 * np.abs(latched), a_max)   # A_max
        expected = np.clip(2.0 * largest / latched * (error - 0.5 * latched) - viscosity * velocity, -a_max, a_max)
        if abs(velocity[0] + expected[0] * dt) < 2.0:
            np.testing.assert_allclose(planner.acceleration, expected, rtol=1e-9, atol=1e-12)
            checked += 1
    assert float(latched[0]) > 1.9 and checked >= 100, (latched, checked)
