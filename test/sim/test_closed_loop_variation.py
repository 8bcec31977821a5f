"""The closed-loop operator's VARYING mode (sim_bridge/device/closed_loop_operator.py): with a seed, every move has its
own size, duration and timing and the hand wanders at random times; without one, nothing varies."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_core.errors import FicInputError
from sim_bridge.device.closed_loop_operator import ClosedLoopOperator, ClosedLoopParameters, Frame

CENTRE = np.array([0.45, 0.0, 0.35])
PUSHABLE = np.array([0.45, -0.10, 0.235])
VARYING = dict(move_amplitude_range=(0.85, 1.1), move_duration_range=(0.7, 1.3), move_timing_spread=0.15)


def lift_peaks(parameters: ClosedLoopParameters, duration: float = 40.0) -> tuple[list[float], np.ndarray]:
    """Circle the TCP at the paper's 5 s lap, seen at once; return each avoid move's peak lift and all targets."""
    operator = ClosedLoopOperator(parameters)
    targets = []
    for ms in range(0, int(duration * 1000), 4):
        now = ms * 1e-3
        if ms % 32 == 0:
            angle = 2.0 * math.pi * now / 5.0
            operator.see(now, Frame(now, CENTRE + 0.1 * np.array([math.cos(angle), math.sin(angle), 0.0]), PUSHABLE))
        targets.append(operator.target(now))
    lift = np.array(targets)[:, 2]
    peaks, inside = [], False
    for value in lift:
        if value > 1e-4 and not inside:
            peaks.append(0.0)
        inside = value > 1e-4
        if inside:
            peaks[-1] = max(peaks[-1], float(value))
    return peaks, np.array(targets)


def test_without_a_seed_every_avoid_move_is_the_scripts() -> None:
    peaks, _ = lift_peaks(ClosedLoopParameters(assumed_one_way_delay=0.0, reaction_time=0.0, **VARYING))
    assert len(peaks) >= 6
    np.testing.assert_allclose(peaks, 0.06, rtol=1e-6)


def test_with_a_seed_each_move_has_its_own_size_within_the_range() -> None:
    parameters = ClosedLoopParameters(assumed_one_way_delay=0.0, reaction_time=0.0, seed=11, **VARYING)
    peaks, targets = lift_peaks(parameters)
    assert len(peaks) >= 6
    assert all(0.85 * 0.06 - 1e-9 <= peak <= 1.1 * 0.06 + 1e-9 for peak in peaks)
    assert np.ptp(peaks) > 0.005
    again, targets_again = lift_peaks(parameters)
    np.testing.assert_array_equal(targets, targets_again)          # the same seed, the same moves


def test_the_wander_starts_at_random_times_and_stays_within_its_amplitude() -> None:
    parameters = ClosedLoopParameters(seed=5, wander_amplitude_range=(0.005, 0.02), wander_period_range=(1.0, 4.0),
                                      wander_mean_gap=3.0)
    operator = ClosedLoopOperator(parameters)   # sees nothing: only the wander moves the hand
    targets = np.array([operator.target(ms * 1e-3) for ms in range(0, 60000, 4)])
    moving = np.linalg.norm(targets, axis=1) > 1e-6
    starts = np.flatnonzero(moving[1:] & ~moving[:-1])
    assert len(starts) >= 5
    assert len(set(np.round(np.diff(starts) * 0.004, 2))) == len(starts) - 1   # the gaps are not one period
    assert np.linalg.norm(targets, axis=1).max() < 3 * 0.02                    # a few overlapping at most
    other = ClosedLoopOperator(ClosedLoopParameters(**{**vars(parameters), "seed": 6}))
    assert not np.allclose(targets, [other.target(ms * 1e-3) for ms in range(0, 60000, 4)])


@pytest.mark.parametrize("change", [dict(move_amplitude_range=(1.1, 0.9)), dict(move_duration_range=(0.0, 1.0)),
                                    dict(wander_mean_gap=0.0), dict(move_timing_spread=-0.1)])
def test_bad_ranges_are_refused(change) -> None:
    with pytest.raises(FicInputError):
        ClosedLoopParameters(**change)
