"""The force profile's parameters at the ends of their documented ranges (profile.py: K0 > 0, x_b > 0, xi in
[0, 1), F_max >= F0 = xi K0 x_b and F_max > 0), for the ForceProfile every controller is built from and for
``force_profile``, Eq. 1 as a function: each end that is in is accepted, the next value past it refused, in one
line naming the parameter."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_core.errors import FicInputError
from fic_core.profile import ForceProfile, force_profile

BELOW_ONE = math.nextafter(1.0, 0.0)
# (stiffness, saturation_error, saturation_start, max_force): each in range, at or next to an end.
ACCEPTED = [
    (0.5, 0.05, 0.5, 10.0),             # a stiffness below 1 N/m
    (200.0, 0.5, 0.5, 50.0),            # a saturation error below 1 m
    (200.0, 0.05, 0.0, 0.5),            # no linear region, a force bound below 1 N
    (200.0, 0.05, BELOW_ONE, 10.0),     # the largest xi below 1
    (200.0, 0.05, 0.5, 0.5 * 200.0 * 0.05),   # F_max = F0 exactly: a profile flat from the linear region's end
]
REFUSED = [
    ((0.0, 0.05, 0.5, 10.0), "stiffness"),
    ((200.0, 0.0, 0.5, 10.0), "saturation_error"),
    ((200.0, 0.05, -5e-324, 10.0), "saturation_start"),
    ((200.0, 0.05, 1.0, 10.0), "saturation_start"),
    ((200.0, 0.05, 0.0, 0.0), "max_force"),
    ((200.0, 0.05, 0.5, math.nextafter(0.5 * 200.0 * 0.05, 0.0)), "max_force"),
]


@pytest.mark.parametrize("values", ACCEPTED)
def test_each_end_in_range_is_accepted(values: tuple[float, float, float, float]) -> None:
    profile = ForceProfile(*values)
    stiffness, saturation_error, saturation_start, max_force = values
    errors = np.array([0.0, 0.3 * saturation_error, 3.0 * saturation_error])
    forces = force_profile(errors, stiffness=stiffness, saturation_error=saturation_error,
                           saturation_start=saturation_start, max_force=max_force)
    np.testing.assert_array_equal(forces, profile.force(errors))
    assert forces[0] == 0.0 and 0.0 < forces[2] <= max_force


@pytest.mark.parametrize(("values", "name"), REFUSED)
def test_the_next_value_past_each_end_is_refused_naming_it(values: tuple[float, float, float, float],
                                                           name: str) -> None:
    stiffness, saturation_error, saturation_start, max_force = values
    with pytest.raises(FicInputError, match=name):
        ForceProfile(*values)
    with pytest.raises(FicInputError, match=name):
        force_profile(0.01, stiffness=stiffness, saturation_error=saturation_error,
                      saturation_start=saturation_start, max_force=max_force)
