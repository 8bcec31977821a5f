"""The linear_tdpa baseline and the FIC feedback-rate cells on the in-process runner (fic_teleop_experiments).

linear_tdpa is linear_bounded behind the channel's time-domain passivity controllers (fic_core/channel_ports.py): at 1 s
each way the channel must generate far less energy with them than without, the observers' deficits must be
smaller, and the offset drift they cost is reported. dynamics_at_physics_rate at 1 kHz must be the plain run (the
arm's C qd + G swapped for the replica's own at the same state is the same torque).
"""
from __future__ import annotations

import numpy as np

from fic_teleop_experiments.in_process import RunConfig, run


def test_the_passivity_controllers_cut_the_energy_the_delay_generates():
    # The E1 script timed for 0.2 s reaches the replica 0.8 s late at 1 s and pushes into the obstacles: contact
    # forces through the delay, which is what the controllers are for (timed for 1 s, 5 s see no contact).
    plain = run(RunConfig(duration=5.0, delay=1.0, controller="linear_bounded", script_delay=0.2))
    passive = run(RunConfig(duration=5.0, delay=1.0, controller="linear_tdpa", script_delay=0.2))
    assert plain.port_energy.shape == passive.port_energy.shape == (plain.time.size, 5)
    generated, generated_passive = plain.port_energy[-1, 2], passive.port_energy[-1, 2]
    assert generated > 0.1                           # the delay does generate energy in E1 (contacts, 1 s)
    assert generated_passive < 0.5 * generated
    assert passive.port_energy[:, :2].min() > 0.5 * plain.port_energy[:, :2].min()
    assert plain.port_energy[:, 4].max() == 0.0 < passive.port_energy[:, 4].max() < 0.05


def test_dynamics_at_the_physics_rate_changes_nothing_at_1_khz():
    plain = run(RunConfig(duration=1.5, delay=0.2))
    swapped = run(RunConfig(duration=1.5, delay=0.2, dynamics_at_physics_rate=True))
    np.testing.assert_allclose(swapped.tcp, plain.tcp, atol=1e-6)
