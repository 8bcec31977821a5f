"""fic_teleop_experiments.lap_median: what repeats at the task's lap is removed, what the loop adds is kept, and one
odd lap stays in its own lap."""
from __future__ import annotations

import numpy as np
import pytest

from fic_teleop_experiments.lap_median import without_lap_median

T = np.arange(0.0, 30.0, 0.01)


def test_a_motion_that_repeats_at_the_lap_is_removed():
    lap = 0.03 * np.sin(2 * np.pi * T / 5.0) + 0.01 * np.cos(2 * np.pi * T / 2.5) + 0.005 * np.sin(6 * np.pi * T / 5.0)
    rest = without_lap_median(T, lap[:, None], 5.0, 8.0)
    assert np.abs(rest[T >= 8.0]).max() < 1e-9
    assert np.array_equal(rest[T < 8.0], lap[T < 8.0, None])   # before the start: not judged, unchanged


def test_what_differs_from_lap_to_lap_is_kept():
    """A 3.3 s oscillation (5 / 3.3 = 1.52: half a cycle off the lap) survives at about its size (the median of 4.4
    laps' phases is not zero, so somewhat more or less); a growth on the lap survives too (the median is the middle
    lap's size)."""
    own = 0.01 * np.sin(2 * np.pi * T / 3.3)
    rest = without_lap_median(T, own[:, None], 5.0, 8.0)[T >= 8.0, 0]
    assert 0.8 * 0.01 < 0.5 * np.ptp(rest) < 1.6 * 0.01
    growing = (T / 30.0) * 0.02 * np.sin(2 * np.pi * T / 5.0)
    rest = without_lap_median(T, growing[:, None], 5.0, 8.0)[T >= 8.0, 0]
    assert np.abs(rest).max() > 0.004


def test_one_odd_lap_stays_in_its_own_lap():
    """The lap's move on every lap but one, where it is three times as large (an obstacle swept on that lap only): the
    other laps are left at zero (a mean would put a fifth of the odd lap on each, the same on each, repeating at the
    lap), the odd lap keeps its difference."""
    move = 0.02 * np.exp(-(((T % 5.0) - 2.5) / 0.3) ** 2)
    odd = (T >= 13.0) & (T < 18.0)
    signal = np.where(odd, 3.0 * move, move)
    rest = without_lap_median(T, signal[:, None], 5.0, 8.0)[:, 0]
    assert np.abs(rest[(T >= 8.0) & ~odd]).max() < 1e-12
    assert np.abs(rest[odd]).max() == pytest.approx(0.04, rel=1e-3)


def test_a_bad_period_is_refused():
    with pytest.raises(ValueError, match="task period must be positive"):
        without_lap_median(T, T[:, None], 0.0, 8.0)
