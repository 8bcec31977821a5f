"""sim_bridge.experiments.lap_mean: what repeats at the task's lap is removed, what the loop adds is kept."""
from __future__ import annotations

import numpy as np
import pytest

from sim_bridge.experiments.lap_mean import without_lap_mean

T = np.arange(0.0, 30.0, 0.01)


def test_a_motion_that_repeats_at_the_lap_is_removed():
    lap = 0.03 * np.sin(2 * np.pi * T / 5.0) + 0.01 * np.cos(2 * np.pi * T / 2.5) + 0.005 * np.sin(6 * np.pi * T / 5.0)
    rest = without_lap_mean(T, lap[:, None], 5.0, 8.0)
    assert np.abs(rest[T >= 8.0]).max() < 1e-9
    assert np.array_equal(rest[T < 8.0], lap[T < 8.0, None])   # before the start: not judged, unchanged


def test_what_differs_from_lap_to_lap_is_kept():
    """A 3.3 s oscillation (5 / 3.3 = 1.52: half a cycle off the lap) survives at about its size (4.4 laps do not
    average it to zero, so up to 1/N more or less); a growth on the lap survives too (the mean averages the laps'
    sizes)."""
    own = 0.01 * np.sin(2 * np.pi * T / 3.3)
    rest = without_lap_mean(T, own[:, None], 5.0, 8.0)[T >= 8.0, 0]
    assert 0.8 * 0.01 < 0.5 * np.ptp(rest) < 1.4 * 0.01
    growing = (T / 30.0) * 0.02 * np.sin(2 * np.pi * T / 5.0)
    rest = without_lap_mean(T, growing[:, None], 5.0, 8.0)[T >= 8.0, 0]
    assert np.abs(rest).max() > 0.004


def test_a_bad_period_is_refused():
    with pytest.raises(ValueError, match="task period must be positive"):
        without_lap_mean(T, T[:, None], 0.0, 8.0)
