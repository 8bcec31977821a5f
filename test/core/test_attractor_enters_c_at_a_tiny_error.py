"""An axis in D enters C when |e| falls past the dead-band from a previous sample on the same side of the target
(docs/CONTROL_LAWS.md), however small the new error: a subnormal e_k on e_{k-1}'s side is on that side (the
product e_{k-1} e_k would underflow to 0 there and miss it). Zero, or the other side, is not."""
from __future__ import annotations

import pytest

from fic_core.attractor import FractalAttractor, Phase
from fic_core.profile import ForceProfile

PROFILE = ForceProfile(stiffness=1000.0, saturation_error=0.05, saturation_start=0.5, max_force=40.0)


@pytest.mark.parametrize("side", [1.0, -1.0])
@pytest.mark.parametrize("tiny", [5e-324, 1e-310, 1e-200])
def test_a_tiny_error_on_the_same_side_enters_c_latching_the_previous_one(side: float, tiny: float) -> None:
    attractor = FractalAttractor(PROFILE, 1, rate_deadband=0.005)
    attractor.force([side * 0.01], [0.0])
    force = attractor.force([side * tiny], [-side * 1.0])   # |e| falling at 1 m/s
    assert attractor.phase.tolist() == [Phase.CONVERGENCE]
    assert attractor.latched_max_error.tolist() == [side * 0.01]
    # C: K_C (e - e_max/2) with K_C = 2 F_c(e_max)/e_max = 2 K0 in the linear range.
    assert force.tolist() == pytest.approx([2.0 * PROFILE.stiffness * (side * tiny - side * 0.005)], rel=1e-12)


@pytest.mark.parametrize("side", [1.0, -1.0])
@pytest.mark.parametrize("error", [0.0, -0.0, -5e-324])
def test_zero_or_the_other_side_stays_in_d(side: float, error: float) -> None:
    attractor = FractalAttractor(PROFILE, 1, rate_deadband=0.005)
    attractor.force([side * 0.01], [0.0])
    attractor.force([side * error], [-side * 1.0])
    assert attractor.phase.tolist() == [Phase.DIVERGENCE]
