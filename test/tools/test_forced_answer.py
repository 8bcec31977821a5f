"""The loop's forced answer to its exogenous input (fic_teleop_tools.verdict.forced_answer) and what the run verdict
does with it: a stable resonant loop's answer is not an oscillation, a free one is, and only exogenous input excuses.

The labels come from closed forms: the second-order replica's peak gain 1/(2 zeta sqrt(1 - zeta^2)) and its
stability for any positive coefficients; the hand loop's instability above the delayed loop's K_crit. The runs here
have no quiet tail: the oscillation scan with the fit is what judges them (a run with a tail is judged by its free
response, test_run_verdict)."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import cont2discrete, lfilter

from fic_teleop_experiments.verdict_cases import (
    HAND_DAMPING,
    HAND_STIFFNESS,
    HANDLE_MASS,
    RESONANT_MASS,
    replica_limit_cycle,
    resonance,
    resonant_plant,
)
from fic_teleop_tools.verdict.forced_answer import Channel, ForcedSettings, fit, free_oscillation_period
from fic_teleop_tools.verdict.run_verdict import VerdictCriterion, judge


def _second_order(u: np.ndarray, natural_hz: float, damping_ratio: float, step: float) -> np.ndarray:
    w = 2.0 * math.pi * natural_hz
    b, a, _ = cont2discrete(([w * w], [1.0, 2.0 * damping_ratio * w, w * w]), step, method="bilinear")
    return lfilter(b.ravel(), a, u)


@pytest.fixture(scope="module")
def driven():
    """An input like an operator's (random moves plus band-limited noise) and a delayed resonant answer to it."""
    rng = np.random.default_rng(3)
    time = np.arange(0.0, 30.0, 0.01)
    u = np.zeros((time.size, 3))
    u[:, 0] = lfilter(*_band(), rng.standard_normal(time.size)) * 0.01 \
        + np.cumsum(rng.standard_normal(time.size)) * 1e-4
    answer = _second_order(u[:, 0], 0.7, 0.3, 0.01)
    residual = np.zeros_like(u)
    residual[:, 0] = np.interp(time - 0.2, time, answer) - np.interp(time - 0.2, time, u[:, 0])
    return time, u, residual


def _band():
    from scipy.signal import butter
    return butter(1, [0.3, 1.5], btype="bandpass", fs=100.0)


def test_the_fit_recovers_a_delayed_resonant_answer_and_its_gain(driven):
    time, u, residual = driven
    answer = fit(time, residual, [Channel("operator target", u, 0.2, unit=True)], time >= 2.0)
    assert answer is not None and answer.explained_share[0] > 0.99
    zeta = 0.3
    peak = 1.0 / (2.0 * zeta * math.sqrt(1.0 - zeta ** 2))
    period = 1.0 / (0.7 * math.sqrt(1.0 - 2.0 * zeta ** 2))
    assert answer.gain["peak_gain"] == pytest.approx(peak, rel=0.03)
    assert answer.gain["period_s"] == pytest.approx(period, rel=0.03)


def test_an_oscillation_independent_of_the_input_is_not_explained(driven):
    """Out of sample, a kernel that played the sinusoid after the input's moves predicts nothing in phase with it."""
    time, u, _ = driven
    free = np.zeros_like(u)
    free[:, 0] = 0.01 * np.sin(2.0 * math.pi * time / 1.45)
    answer = fit(time, free, [Channel("operator target", u, 0.2, unit=True)], time >= 2.0)
    assert answer is not None and answer.explained_share[0] < 0.1
    left = free - answer.predicted
    assert np.std(left[time >= 2.0, 0]) > 0.9 * np.std(free[time >= 2.0, 0])


def test_a_free_oscillations_period_is_found_jointly_with_the_kernels(driven):
    """A 10 mm cycle at the resonance (1.58 s) beside the resonant answer: from a hint 5 % off either way (the scan's
    grid is 7 % coarse) the joint fit of the kernels and a free sinusoid leaves least at the cycle's period. (The
    labelled miss this fixed, where the kernels alone took part of the cycle, is in test_run_verdict.)"""
    time, u, residual = driven
    period = 1.0 / (0.7 * math.sqrt(1.0 - 2.0 * 0.3 ** 2))
    cycle = residual.copy()
    cycle[:, 0] += 0.01 * np.sin(2.0 * math.pi * time / period + 0.7)
    channels, use = [Channel("operator target", u, 0.2, unit=True)], time >= 2.0
    found = free_oscillation_period(time, cycle, channels, use, 1.05 * period)
    assert found == pytest.approx(period, rel=0.005)
    assert free_oscillation_period(time, cycle, channels, use, 0.95 * period) == pytest.approx(period, rel=0.005)
    # No cycle: the search still returns a period within its spread (the fit beside it then takes nothing steady).
    assert abs(free_oscillation_period(time, residual, channels, use, period) / period - 1.0) <= 0.15 + 1e-9


def test_too_few_samples_is_no_fit(driven):
    time, u, residual = driven
    assert fit(time, residual, [Channel("operator target", u, 0.2)], time >= 28.5) is None   # 30 rows, 18 parameters


@pytest.fixture(scope="module")
def forced_run():
    return resonant_plant(1.0, 1, 10.0, tail=0.0)   # no quiet tail: the oscillation scan decides (run_verdict)


def test_a_forced_resonance_is_stable_and_its_gain_is_reported(forced_run):
    """The replica's peak gain (closed form 1.80 at 1.46 s) times the hand's (B s + K)/(m s^2 + B s + K) there is
    what the verdict reports as the loop's resonant amplification; the rule without the fit calls the run
    unstable (its blind spot)."""
    stiffness, damping, peak, period = resonance()
    w = np.linspace(0.5, 12.0, 20000)
    s = 1j * w
    replica = stiffness / (RESONANT_MASS * s ** 2 + damping * s + stiffness)
    hand = (1.5 * HAND_DAMPING * s + HAND_STIFFNESS) / (HANDLE_MASS * s ** 2 + 1.5 * HAND_DAMPING * s + HAND_STIFFNESS)
    assert np.abs(replica).max() == pytest.approx(peak, rel=1e-3)
    both = np.abs(replica * hand)
    verdict = judge(forced_run)
    assert verdict.stable is True, verdict.stable_reasons
    assert verdict.figures["resonance_gain"] == pytest.approx(both.max(), rel=0.05)
    assert verdict.figures["resonance_period_s"] == pytest.approx(2.0 * math.pi / w[both.argmax()], rel=0.05)
    assert 2.0 * math.pi / w[np.abs(replica).argmax()] == pytest.approx(period, rel=1e-3)
    without = judge(forced_run, replace(VerdictCriterion(), forced=ForcedSettings(enabled=False)))
    assert without.stable is False and any("x_R - command" in r for r in without.stable_reasons)
    assert any("forced answer" in note for note in verdict.notes)


@pytest.mark.parametrize("amplitude", [0.005, 0.03])
def test_a_free_oscillation_at_the_resonant_period_is_not_excused(forced_run, amplitude: float):
    verdict = judge(replica_limit_cycle(forced_run, amplitude, resonance()[3]))
    assert verdict.stable is False
    assert any("x_R - command beyond its forced answer" in r for r in verdict.stable_reasons)


def test_only_exogenous_input_excuses_an_oscillation_the_command_carries():
    """The hand loop's limit cycle is in x_M, so in x_d and in what the replica receives: the fit's inputs (the
    planner, the operator's target) do not hold it, so it stays; given the handle itself as the 'target' (a signal
    inside the loop) the same oscillation would be taken for an answer."""
    data = resonant_plant(0.2, 3, 10.0, duration=33.0, hand_loop_gain=1.5, tail=0.0)
    verdict = judge(data)
    assert verdict.stable is False
    assert any(r.startswith("sustained oscillation of x_d - command beyond") for r in verdict.stable_reasons)
    fooled = replace(data, operator_target=data.x_M, command=data.planner + np.column_stack(
        [np.interp(data.time - 0.2, data.time, data.x_M[:, j]) for j in range(3)]))
    assert judge(fooled).stable is True


def test_without_exogenous_input_the_rule_is_the_conservative_one(forced_run):
    bare = replace(forced_run, planner=None, operator_target=None, command=None, x_M=None)
    verdict = judge(bare)
    assert "resonance_gain" not in verdict.figures
    assert any("conservative rule" in note for note in verdict.notes)
