"""A graph run's bag is judged by the one run verdict (fic_teleop_experiments.runner.stability_of over
fic_teleop_tools.verdict.run_verdict): series as a bag gives them, a loop at rest against one in a growing
oscillation, the whole run and a window of it (E3's time after the link is lost)."""
from __future__ import annotations

import numpy as np

from fic_teleop_experiments.runner import stability_of
from fic_teleop_tools.verdict.bag_series import RunSeries

DELAY = 0.2
RATE = 100.0


def _bag_series(amplitude_growth: float, duration: float = 20.0) -> RunSeries:
    """/replica/fic_state at 100 Hz: x_d - x_R a 1.5 s oscillation of 2 mm scaled by exp(growth t), its energy."""
    time = np.arange(0.0, duration, 1.0 / RATE)
    swing = 0.002 * np.exp(amplitude_growth * time) * np.sin(2.0 * np.pi * time / 1.5)
    error = np.column_stack([swing, 0.5 * swing, np.zeros_like(swing)])
    energy = 0.5 * 200.0 * np.sum(error ** 2, axis=1)
    limits = np.arange(0.0, duration, 0.1)
    return RunSeries(fic_time=time, error=error, total_energy=energy, master_stale=np.zeros(time.size, bool),
                     controller="fic", limit_time=limits, violation_ticks=np.zeros(limits.size),
                     shaped_ticks=np.zeros(limits.size))


def test_a_loop_that_settles_is_stable_and_one_that_grows_is_not():
    settled = stability_of(_bag_series(-0.5), DELAY)
    assert settled["stable"] is True and settled["safe"] is True, settled["reasons"]
    growing = stability_of(_bag_series(0.25), DELAY)
    assert growing["stable"] is False and growing["reasons"], growing
    assert growing["max_error"] > growing["max_error_last_half"] * 0.99
    assert growing["max_error_last_half"] > 0.1


def test_a_window_is_judged_on_its_own_samples():
    series = _bag_series(-0.5)
    after = stability_of(series, DELAY, start=10.0)
    assert 9.5 < after["figures"]["duration_s"] < 10.5
    assert after["stable"] is True
    too_short = stability_of(series, DELAY, start=15.0)
    assert too_short["stable"] is None and too_short["reasons"][0].startswith("not assessed")


def test_a_bag_without_the_replicas_state_is_not_judged():
    assert stability_of(RunSeries(), DELAY) == {"stable": None, "safe": None,
                                               "reasons": ["no /replica/fic_state in the bag"]}
