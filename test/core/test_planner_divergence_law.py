"""The planner's D phase is paper Eq. 5's D line with its viscous term: a = sign(x~_t) min(w_n^2 |x~_t|, a_max) - mu v,
mu = 0.01 w_n. The term is small (a hundredth of w_n), so a run's figures do not show its sign; the law's
acceleration, step by step, does."""
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
