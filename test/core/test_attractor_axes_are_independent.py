"""Paper Eq. 2 acts per axis: an n-axis FractalAttractor gives, tick by tick, the forces, phases and storages of n
one-axis attractors fed each its own axis (the oracle). The phase logic has two paths: the common tick, where no
axis switches, and the switching tick, which recomputes every axis; an axis's phase must not depend on which of
the two another axis sent the tick to. The rates are drawn from a grid that holds d|e|/dt exactly at the
dead-band (a power of two, so -rate_deadband is exact): "past the dead-band" enters C, at it stays in D, on a
switching tick as on a common one."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.attractor import FractalAttractor
from fic_core.profile import ForceProfile

PROFILE = ForceProfile(stiffness=1000.0, saturation_error=0.05, saturation_start=0.5, max_force=40.0)
DEADBAND = 2.0 ** -4   # [m/s]
AXES = 3


def run(seed: int, ticks: int = 240) -> None:
    generator = np.random.default_rng(seed)
    joint = FractalAttractor(PROFILE, AXES, DEADBAND)
    single = [FractalAttractor(PROFILE, 1, DEADBAND) for _ in range(AXES)]
    errors = generator.choice([-0.06, -0.02, 0.0, 0.01, 0.03, 0.08], size=AXES)
    rate_grid = np.array([-4.0, -2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0]) * DEADBAND
    at_the_deadband = 0
    for tick in range(ticks):
        # d|e|/dt = sign(e) de/dt: exactly -DEADBAND at rate = -sign(e) DEADBAND, one of the grid's values.
        rates = generator.choice(rate_grid, size=AXES)
        errors = np.round(errors + generator.choice([-1.0, 0.0, 1.0], size=AXES) * 2.0 ** -8, 10)
        errors[generator.random(AXES) < 0.05] = 0.0
        at_the_deadband += int(np.sum(np.sign(errors) * rates == -DEADBAND))
        forces = joint.force(errors, rates)
        for axis, attractor in enumerate(single):
            alone = attractor.force(errors[axis:axis + 1], rates[axis:axis + 1])
            assert forces[axis] == alone[0], (seed, tick, axis)
            assert joint.phase[axis] == attractor.phase[0], (seed, tick, axis)
            assert joint.latched_max_error[axis] == attractor.latched_max_error[0], (seed, tick, axis)
            assert joint.stored_energy[axis] == attractor.stored_energy[0], (seed, tick, axis)
    assert at_the_deadband > 10   # the grid reaches the dead-band itself


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_an_n_axis_attractor_is_n_one_axis_attractors(seed: int) -> None:
    run(seed)


def test_an_axis_exactly_at_the_deadband_stays_in_d_while_another_enters_c() -> None:
    """The case written out: axis 0 decreasing past the dead-band enters C (a switching tick), axis 1 decreasing
    exactly at it stays in D, with F_c(e) of Eq. 1; one float past the dead-band it enters C too."""
    for rate, entered in ((-DEADBAND, False), (np.nextafter(-DEADBAND, -1.0), True)):
        attractor = FractalAttractor(PROFILE, 2, DEADBAND)
        attractor.force([0.03, 0.03], [0.0, 0.0])
        force = attractor.force([0.02, 0.02], [-1.0, rate])
        assert attractor.phase[0] == 1
        assert attractor.phase[1] == int(entered)
        if not entered:
            assert force[1] == PROFILE.scalar_force(0.02)
