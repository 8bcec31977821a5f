"""The planner's strictly positive parameters (its docstring: w_n > 0, v_d > 0, v_p > 0) are refused at exactly zero,
each by name in one line, and accepted at the smallest positive float; the two that may be zero (the rate
dead-band and the retarget tolerance) are accepted at zero and refused below it."""
from __future__ import annotations

import math

import pytest

from fic_core.errors import FicInputError
from fic_core.planner import HarmonicPlanner

VALID = dict(natural_frequency=5.0, max_velocity=0.5, velocity_peak_ratio=1.0, rate_deadband=0.0,
             retarget_tolerance=1e-9)
TINY = math.ulp(0.0)


@pytest.mark.parametrize("name", ["natural_frequency", "max_velocity", "velocity_peak_ratio"])
def test_a_strictly_positive_parameter_is_refused_at_zero_by_name(name: str) -> None:
    with pytest.raises(FicInputError, match=name):
        HarmonicPlanner(**{**VALID, name: 0.0})
    HarmonicPlanner(**{**VALID, name: TINY})


@pytest.mark.parametrize("name", ["rate_deadband", "retarget_tolerance"])
def test_a_non_negative_parameter_is_accepted_at_zero_and_refused_below(name: str) -> None:
    HarmonicPlanner(**{**VALID, name: 0.0})
    with pytest.raises(FicInputError, match=name):
        HarmonicPlanner(**{**VALID, name: -TINY})
