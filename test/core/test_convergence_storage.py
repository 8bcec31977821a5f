"""The storage of an axis in C (attractor.convergence_storage, the module docstring's V_C): V_latch plus the work
of the clipped C force F_C(e) = clip(K_C (e - e_max/2), +-F_max) from e_max to e, checked against that integral
taken numerically, for C stiffnesses from a soft profile's (below 1 N/m) to a stiff one's, inside and past the
clip (K_C no larger than Eq. 2 makes it: the storage's premise); with K_C = 0 there is no C force and the
storage stays V_latch."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.attractor import convergence_storage
from fic_core.profile import ForceProfile


def integral_of_the_c_force(profile: ForceProfile, latched: float, stiffness: float, error: float) -> float:
    grid = np.linspace(latched, error, 200_001)
    force = np.clip(stiffness * (grid - 0.5 * latched), -profile.max_force, profile.max_force)
    return float(np.sum(0.5 * (force[1:] + force[:-1]) * np.diff(grid)))


@pytest.mark.parametrize("stiffness", [0.25, 0.5, 1.0, 40.0, 125.0])
@pytest.mark.parametrize("fraction", [0.9, 0.5, 0.0, -0.3, -2.0])
@pytest.mark.parametrize("latched", [0.04, -0.04])
def test_the_c_storage_is_v_latch_plus_the_work_of_the_clipped_c_force(stiffness: float, fraction: float,
                                                                       latched: float) -> None:
    # F_max = 2.5 N; K_C at most 2 F_max/|e_max| = 125 N/m (as Eq. 2's K_C always is: K_C |e_max|/2 <= F_latch <=
    # F_max), which clips from 20 mm past the mid-point on.
    profile = ForceProfile(200.0, 0.05, 0.2, 2.5)
    latched_energy = profile.scalar_energy(latched)
    error = fraction * latched
    expected = latched_energy + integral_of_the_c_force(profile, latched, stiffness, error)
    assert convergence_storage(profile, latched, stiffness, latched_energy, error) == pytest.approx(
        expected, rel=1e-9, abs=1e-12)


def test_without_a_c_stiffness_the_storage_is_v_latch() -> None:
    profile = ForceProfile(200.0, 0.05, 0.2, 2.5)
    for error in (0.04, 0.01, -0.03):
        assert convergence_storage(profile, 0.04, 0.0, 0.123, error) == 0.123
