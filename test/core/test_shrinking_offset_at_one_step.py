"""A jump taken out of a set-point (set_point.ShrinkingOffset) is given back at its speed: an offset no longer than
one tick's step is given back whole, the set-point is then the commanded one and the give-back is over. At the
ends of that test: an offset exactly one step long (binary fractions: |(0.75, 1, 0)| = 1.25 to the bit), and a
subnormal offset whose norm underflows to 0 on a tick of no time (step 0): the set-point stays finite and ends at
the commanded one, within the offset; a tick of no time leaves a normal offset as it is."""
from __future__ import annotations

import numpy as np

from fic_core.set_point import ShrinkingOffset

COMMANDED = np.array([0.5, -0.25, 0.125])


def test_an_offset_exactly_one_step_long_is_given_back_whole() -> None:
    jump = ShrinkingOffset()
    jump.start(COMMANDED + np.array([0.75, 1.0, 0.0]), COMMANDED, 1.25)
    assert jump.active
    np.testing.assert_array_equal(jump.apply(COMMANDED, 0.5), COMMANDED + np.array([0.375, 0.5, 0.0]))
    jump.start(COMMANDED + np.array([0.75, 1.0, 0.0]), COMMANDED, 1.25)
    np.testing.assert_array_equal(jump.apply(COMMANDED, 1.0), COMMANDED)
    assert not jump.active and not jump.offset.any()


def test_a_subnormal_offset_on_a_tick_of_no_time_stays_finite() -> None:
    tiny = np.array([5e-324, 0.0, -5e-324])
    assert np.sqrt(tiny @ tiny) == 0.0   # its norm underflows
    jump = ShrinkingOffset()
    jump.start(tiny, np.zeros(3), 0.1)
    assert jump.active
    point = jump.apply(np.zeros(3), 0.0)
    assert np.all(np.isfinite(point)) and np.all(np.abs(point) <= np.abs(tiny))
    assert np.all(np.isfinite(jump.offset))
    np.testing.assert_array_equal(jump.apply(np.zeros(3), 0.001), np.zeros(3))
    assert not jump.active


def test_a_tick_of_no_time_leaves_the_offset_as_it_is() -> None:
    jump = ShrinkingOffset()
    jump.start(COMMANDED + np.array([0.75, 1.0, 0.0]), COMMANDED, 1.25)
    np.testing.assert_array_equal(jump.apply(COMMANDED, 0.0), COMMANDED + np.array([0.75, 1.0, 0.0]))
    assert jump.active
