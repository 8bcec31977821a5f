"""The replica's frequency response from open-loop runs (fic_teleop_experiments.replica_response) on signals whose
answer is known: perfect tracking, a resonance's gain, a pure delay's phase."""
from __future__ import annotations

import numpy as np
import pytest

from fic_teleop_experiments.replica_response import response

RATE = 50.0
TIME = np.arange(0.0, 28.0, 1.0 / RATE)


def _input(seed: int = 3) -> np.ndarray:
    """A band-limited random offset on three axes (an operator's moves: power from 0.1 to 3 Hz)."""
    draws = np.random.default_rng(seed)
    signal = np.zeros((TIME.size, 3))
    for frequency in np.arange(0.1, 3.0, 0.05):
        signal += draws.normal(size=3) * 2e-3 * np.sin(2 * np.pi * frequency * TIME[:, None] + draws.uniform(0, 6, 3))
    return signal


def test_an_arm_that_follows_exactly_has_unit_gain_no_phase_and_full_coherence() -> None:
    u = _input()
    f, transfer, coherence = response(TIME, u, u.copy())
    band = (f > 0.2) & (f < 2.0)
    assert np.abs(transfer[band]) == pytest.approx(1.0, abs=1e-6)
    assert np.angle(transfer[band]) == pytest.approx(0.0, abs=1e-6)
    assert coherence[band] == pytest.approx(1.0, abs=1e-6)


def test_a_gain_and_a_delay_are_read_back() -> None:
    u = _input()
    delay = 0.1
    shift = int(round(delay * RATE))
    x = 1.7 * np.roll(u, shift, axis=0)
    f, transfer, _ = response(TIME[shift:], u[shift:], x[shift:])
    band = (f > 0.3) & (f < 1.5)
    assert np.median(np.abs(transfer[band])) == pytest.approx(1.7, rel=0.05)
    # A pure delay's phase is -360 f delay degrees.
    expected = -2 * np.pi * f[band] * delay
    assert np.angle(transfer[band]) == pytest.approx(expected, abs=0.15)


def test_output_noise_unrelated_to_the_input_lowers_the_coherence_not_the_gain() -> None:
    u = _input()
    noise = _input(seed=11)
    f, transfer, coherence = response(TIME, u, u + noise)
    band = (f > 0.3) & (f < 1.5)
    assert np.median(np.abs(transfer[band])) == pytest.approx(1.0, abs=0.35)
    assert np.median(coherence[band]) < 0.8
