"""A new sample's distance from where the hold had got to is blended out over blend_time from the sample's arrival
(fic_core.set_point): the whole distance at the arrival and at any read stamped before it (a clock stepped back:
the hold neither runs backwards nor overshoots its own output), a linear share in between, none after blend_time.
Figures on binary fractions: samples 1/64 s apart, blend_time 1/16 s, no extrapolation past the arrival. With no
blend_time a sample is a step."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.set_point import SampledSetPoint


def test_the_jump_is_whole_at_and_before_the_arrival_and_blended_out_linearly() -> None:
    hold = SampledSetPoint(1, max_extrapolation=0.0, blend_time=0.0625)
    hold.add(0.0, [0.0], received=0.0)
    hold.add(0.015625, [0.5], received=0.015625)   # the hold was at 0: a jump of -0.5 to blend out
    arrival = 0.015625
    for before in (0.0, 0.001, 0.0625):
        assert hold.position(arrival - before).tolist() == [0.0]
    for fraction in (0.25, 0.5, 0.75):
        assert hold.position(arrival + fraction * 0.0625)[0] == pytest.approx(0.5 * fraction, abs=1e-15)
    for after in (0.0625, 0.1, 1.0):
        np.testing.assert_array_equal(hold.position(arrival + after), [0.5])


def test_with_no_blend_time_a_sample_is_a_step() -> None:
    hold = SampledSetPoint(1, max_extrapolation=0.0, blend_time=0.0)
    hold.add(0.0, [0.0], received=0.0)
    hold.add(0.015625, [0.5], received=0.015625)
    for at in (0.0, 0.015625, 0.02, 1.0):
        assert hold.position(at).tolist() == [0.5]
