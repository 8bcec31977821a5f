"""Eq. 5's phase switch on d|x~_t|/dt (docs/CONTROL_LAWS.md), x~_t = x_t - x_d'': an axis in D enters C when the
magnitude of its error falls faster than the dead-band, and stays in C while it falls on the side it entered on.
The magnitude of a zero error has no rate to fall at, so a target landing exactly on x_d'' enters no axis into C,
whatever the target's and x_d'''s velocities, and an axis at rest on its target stays in D."""
from __future__ import annotations

import numpy as np

from fic_core.attractor import Phase
from fic_core.planner import HarmonicPlanner


def test_a_target_exactly_on_x_d_enters_no_axis_into_convergence() -> None:
    """The target runs away at 0.5 m/s (x_d'' chases it in D), then jumps back onto x_d''."""
    planner = HarmonicPlanner(8.0, 0.25)
    planner.reset(np.zeros(3))
    for k in range(1, 11):
        position = planner.step([0.005 * k, 0.0, 0.0], 0.01)
    assert planner.velocity[0] > 0.1 and planner.phase[0] == int(Phase.DIVERGENCE)
    planner.step(position.copy(), 0.01)   # x~_t = 0 on every axis
    assert planner.phase.tolist() == [int(Phase.DIVERGENCE)] * 3
    assert np.isfinite(planner.acceleration).all() and np.isfinite(planner.velocity).all()


def test_the_phase_switch_is_eq_5s_written_out() -> None:
    """Tick by tick along a 0.5 Hz sine target (5 cm on x, 2 cm on y) with a 0.05 m/s dead-band, the rate
    sign(x~_t) (x_t' - x_d''') from before the tick (x_t' the target's difference quotient, 0 on the first tick):
    an axis in D enters C exactly when the rate is below -0.05 m/s; an axis in C stays in C exactly while the rate
    is below 0 and x~_t is on the side of x~_T0, its error on the tick it entered."""
    dt, deadband = 0.01, 0.05
    planner = HarmonicPlanner(8.0, 0.25, rate_deadband=deadband)
    planner.reset(np.zeros(3))
    previous_target = None
    latched = np.zeros(3)
    entered = stayed_in_d = stayed_in_c = left_c = 0
    for k in range(400):
        target = np.array([0.05 * np.sin(np.pi * k * dt), 0.02 * np.cos(np.pi * k * dt), 0.0])
        position, velocity, phase = planner.position, planner.velocity, planner.phase
        error = target - position
        target_velocity = np.zeros(3) if previous_target is None else (target - previous_target) / dt
        rate = np.sign(error) * (target_velocity - velocity)
        planner.step(target, dt)
        for axis in range(3):
            in_c = planner.phase[axis] == int(Phase.CONVERGENCE)
            if phase[axis] == int(Phase.DIVERGENCE):
                enters = bool(rate[axis] < -deadband)
                assert in_c == enters, (k, axis, rate[axis])
                entered += enters
                stayed_in_d += not enters
                if enters:
                    latched[axis] = error[axis]
            else:
                stays = bool(rate[axis] < 0.0 and np.sign(error[axis]) == np.sign(latched[axis]))
                assert in_c == stays, (k, axis, rate[axis])
                stayed_in_c += stays
                left_c += not stays
        previous_target = target
    assert min(entered, left_c) >= 4 and min(stayed_in_d, stayed_in_c) >= 50, (entered, left_c, stayed_in_d,
                                                                               stayed_in_c)
