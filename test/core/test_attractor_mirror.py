"""The attractor is odd in the error (paper Eqs. 1-2 are: F_c(-e) = -F_c(e), D and C alike, and the phase is chosen
by d|e|/dt, which does not change when the error and its rate change sign): any error sequence and its mirror image
give the same phases and exactly opposite forces and latched errors, tick by tick, on every axis. A property over
sequences that enter and leave C, dwell on the target and cross it."""
from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.attractor import FractalAttractor
from fic_core.profile import ForceProfile

PROFILE = ForceProfile(200.0, 0.05, 0.5, 10.0)
PERIOD = 0.002

steps = st.lists(st.sampled_from([0.0, 0.001, -0.001, 0.004, -0.004, 0.02, -0.02, 0.06, -0.06]), min_size=6,
                 max_size=40)


def _run(errors: np.ndarray, rates: np.ndarray) -> tuple[list, list, list]:
    attractor = FractalAttractor(PROFILE, 3, rate_deadband=0.005)
    forces, phases, latched = [], [], []
    for error, rate in zip(errors, rates):
        forces.append(attractor.force(error, rate))
        snapshot = attractor.snapshot()
        phases.append(np.asarray(snapshot.phase).copy())
        latched.append(np.asarray(attractor.latched_max_error, dtype=float).copy())
    return forces, phases, latched


@settings(max_examples=60, deadline=None, derandomize=True)
@given(first=steps, second=steps, third=steps, start=st.sampled_from([0.0, 0.03, -0.08]))
def test_a_mirrored_error_sequence_gives_mirrored_forces(first: list[float], second: list[float],
                                                         third: list[float], start: float) -> None:
    ticks = min(len(first), len(second), len(third))
    increments = np.array([first[:ticks], second[:ticks], third[:ticks]]).T
    errors = start + np.cumsum(increments, axis=0)
    rates = increments / PERIOD
    rates[::5] = 0.0                    # a rate of exactly zero now and then (an error that stops)
    forces, phases, latched = _run(errors, rates)
    mirrored_forces, mirrored_phases, mirrored_latched = _run(-errors, -rates)
    for k in range(ticks):
        np.testing.assert_array_equal(mirrored_forces[k], -forces[k])
        np.testing.assert_array_equal(mirrored_phases[k], phases[k])
        np.testing.assert_array_equal(mirrored_latched[k], -latched[k])
