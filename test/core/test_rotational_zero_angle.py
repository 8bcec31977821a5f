"""A rotation error of zero (below the smallest angle the axis r/theta is defined for) is the rest state of the
rotational FIC: no moment, and the angle's port reports theta = 0, FIC(0) = 0 and no storage, in D, whatever came
before (a rotation held in D, or in C where the storage lets it leave); the next rotation starts from that
rest."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.attractor import Phase
from fic_core.profile import ForceProfile
from fic_core.rotational_attractor import RotationalAttractor

PROFILE = ForceProfile(20.0, 0.5, 0.5, 5.0)
AXIS = np.array([0.6, 0.0, 0.8])


def driven(converging: bool) -> RotationalAttractor:
    attractor = RotationalAttractor(PROFILE, rate_deadband=0.001)
    attractor.moment(0.3 * AXIS, 0.5 * AXIS)
    if converging:
        attractor.moment(0.25 * AXIS, -0.5 * AXIS)
        assert attractor.snapshot().phase.tolist() == [Phase.CONVERGENCE] * 3
    return attractor


@pytest.mark.parametrize("converging", [False, True])
@pytest.mark.parametrize("zero", [np.zeros(3), np.array([1e-13, 0.0, 0.0])])
def test_a_zero_rotation_is_the_rest_state_whatever_came_before(converging: bool, zero: np.ndarray) -> None:
    attractor = driven(converging)
    np.testing.assert_array_equal(attractor.moment(zero, 0.3 * AXIS), np.zeros(3))
    snapshot = attractor.snapshot()
    assert snapshot.port_values() == ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), [0.0, 0.0, 0.0])
    assert snapshot.stored_energy.tolist() == [0.0, 0.0, 0.0]
    assert snapshot.phase.tolist() == [Phase.DIVERGENCE] * 3
    assert snapshot.scalar.errors == (0.0,) and snapshot.scalar.forces == (0.0,)


def test_after_a_zero_rotation_the_next_one_is_taken_as_from_rest() -> None:
    fresh = RotationalAttractor(PROFILE, rate_deadband=0.001)
    attractor = driven(True)
    attractor.moment(np.zeros(3), np.zeros(3))
    for rotation, rate in ((0.1 * AXIS, 0.5 * AXIS), (0.2 * AXIS, 0.5 * AXIS)):
        np.testing.assert_array_equal(attractor.moment(rotation, rate), fresh.moment(rotation, rate))
        assert attractor.snapshot().stored_energy.tolist() == fresh.snapshot().stored_energy.tolist()
    assert float(attractor.snapshot().stored_energy[0]) == pytest.approx(PROFILE.scalar_energy(0.2), rel=1e-12)
