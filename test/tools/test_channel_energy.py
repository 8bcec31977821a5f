"""Two-port energy of the delay channel (fic_teleop_tools.report.metrics.port_energy): a delayed spring is active."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_teleop_tools.report.metrics import port_energy


@pytest.mark.parametrize("delay", [0.0, 0.05, 0.2])
def test_a_round_trip_delay_on_a_spring_generates_the_energy_theory_says(delay: float) -> None:
    """x_d' = A sin(w t) sent, received T later; the replica's spring answers F_R = -k x_received, which the master
    receives T later. Per period the master port passes -k pi A^2 sin(2 w T) (it is pushed by the stale spring),
    the replica port nothing: the channel generates k pi A^2 sin(2 w T) per period."""
    k, amplitude, omega, periods, dt = 200.0, 0.02, 2 * math.pi, 4, 1e-3
    t = np.arange(0.0, periods * 2 * math.pi / omega, dt)
    sent = amplitude * np.sin(omega * t)[:, None] * np.array([1.0, 0.0, 0.0])
    received = amplitude * np.sin(omega * (t - delay))[:, None] * np.array([1.0, 0.0, 0.0])
    replica_force = -k * received
    master_force = -k * amplitude * np.sin(omega * (t - 2 * delay))[:, None] * np.array([1.0, 0.0, 0.0])
    entered = port_energy(t, sent, t, master_force)
    left = port_energy(t, received, t, replica_force)
    expected = periods * k * math.pi * amplitude ** 2 * math.sin(2 * omega * delay)
    # O(dt) terms of the sampled sums: k/2 sum (dx)^2, about 3 mJ here.
    assert left - entered == pytest.approx(expected, abs=5e-3, rel=0.02)


def test_port_energy_holds_the_latest_force_and_needs_two_samples() -> None:
    assert port_energy(np.array([0.0]), np.zeros((1, 3)), np.array([]), np.zeros((0, 3))) == 0.0
    positions = np.array([[0.0, 0, 0], [0.1, 0, 0], [0.2, 0, 0]])
    forces = np.array([[-1.0, 0, 0]])
    # Each step uses the force held at its end; it arrives at t = 1.5: the first step sees none, the second -1 N.
    assert port_energy(np.array([0.0, 1.0, 2.0]), positions, np.array([1.5]), forces) == pytest.approx(0.1)
