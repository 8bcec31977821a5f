"""An axis stays in C only while |e| decreases on the side of the target where it latched e_max (docs/CONTROL_LAWS.md):
an error exactly on the target, or past it, is on neither side or the other one, and the axis returns to D there
(where the storage allows, as it does in the linear range), whatever the caller's error rate says. And at the
C -> D test the boundary V_D(e_{k-1}) == V_C(e_{k-1}) is a return to D: it needs V_D <= V_C, not <."""
from __future__ import annotations

import pytest

from fic_core.attractor import FractalAttractor, Phase
from fic_core.profile import ForceProfile

# Linear range |e| <= xi x_b = 0.025: F_c = K0 e, and the C -> D switch is never deferred there (V_D < V_C).
PROFILE = ForceProfile(stiffness=1000.0, saturation_error=0.05, saturation_start=0.5, max_force=40.0)


def _in_convergence_from(side: float) -> FractalAttractor:
    """One axis that entered C from e = side x 0.01 (|e| falling at 1 m/s): e_max = side x 0.01, K_C = 2 K0."""
    attractor = FractalAttractor(PROFILE, 1, rate_deadband=0.005)
    attractor.force([side * 0.01], [0.0])
    attractor.force([side * 0.008], [side * -1.0])
    assert attractor.phase.tolist() == [Phase.CONVERGENCE]
    assert attractor.latched_max_error.tolist() == [side * 0.01]
    return attractor


@pytest.mark.parametrize("side", [1.0, -1.0])
@pytest.mark.parametrize("on_target", [0.0, -0.0])
@pytest.mark.parametrize("rate", [1.0, -1.0, 0.0])
def test_an_error_exactly_on_the_target_returns_the_axis_to_d_with_zero_force(side: float, on_target: float,
                                                                             rate: float) -> None:
    """e = 0 exactly, with any rate: D, and F_c(0) = 0 (C would give K_C (0 - e_max/2) = -side x 10 N)."""
    attractor = _in_convergence_from(side)
    force = attractor.force([on_target], [rate])
    assert attractor.phase.tolist() == [Phase.DIVERGENCE]
    assert force.tolist() == [0.0]


@pytest.mark.parametrize("side", [1.0, -1.0])
@pytest.mark.parametrize("past", [0.002, 5e-324, 0.02])
def test_an_error_past_the_target_returns_the_axis_to_d_even_while_its_magnitude_falls(side: float,
                                                                                      past: float) -> None:
    """e on the other side of the target with |e| falling (the rate toward the target): D, F = K0 e there (C
    would give K_C (e - e_max/2), about ten times more at e = 2 mm)."""
    attractor = _in_convergence_from(side)
    error = -side * past
    force = attractor.force([error], [side * 1.0])   # sign(e) de/dt = -1 m/s: |e| falls
    assert attractor.phase.tolist() == [Phase.DIVERGENCE]
    assert force.tolist() == [PROFILE.stiffness * error]


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_equal_storages_at_the_c_to_d_test_return_the_axis_to_d(side: float) -> None:
    """Powers of two make the storages equal to the last bit: K0 = 1024, e_max = e_{k-1} = 2^-7 (an axis that
    entered C on a sample equal to the last, its rate already falling) gives V_D(e_max) = 2^-5 J, K_C = 2 K0, and
    V_C(e_max) = V_latch + K_C (e_max/2)^2/2 - K_C e_max^2/8 = 2^-5 + 2^-6 - 2^-6, exact. |e| then grows: the test
    V_D(e_{k-1}) <= V_C(e_{k-1}) holds with equality, and the axis is in D with F = K0 e."""
    profile = ForceProfile(stiffness=1024.0, saturation_error=0.05, saturation_start=0.5, max_force=40.0)
    latched = side * 2.0 ** -7
    attractor = FractalAttractor(profile, 1, rate_deadband=0.005)
    attractor.force([latched], [0.0])
    attractor.force([latched], [-side])   # the same sample, |e| falling at 1 m/s: enters C with e_max = e_{k-1}
    assert attractor.phase.tolist() == [Phase.CONVERGENCE]
    assert attractor.latched_max_error.tolist() == [latched]
    assert attractor.stored_energy.tolist() == [2.0 ** -5]
    grown = side * 0.0125
    force = attractor.force([grown], [side])
    assert attractor.phase.tolist() == [Phase.DIVERGENCE]
    assert force.tolist() == [1024.0 * grown]
