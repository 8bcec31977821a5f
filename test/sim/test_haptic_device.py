"""The sigma.7-class device model (sim_bridge/device/haptic_device.py): dynamics, saturation, walls, closed loop."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_core.errors import FicInputError
from sim_bridge.device.haptic_device import HapticDevice, HapticDeviceParameters

PARAMETERS = HapticDeviceParameters()


def test_a_constant_force_accelerates_the_mass_as_newton_says():
    device = HapticDevice()
    force = np.array([2.0, -1.0, 0.5])
    t = 0.05
    state = device.step(force, np.zeros(3), t)
    # m dv/dt = F - b v from rest: v = F/b (1 - exp(-t/tau)), x = F/b (t - tau (1 - exp(-t/tau))), tau = m/b.
    m, b = PARAMETERS.mass, PARAMETERS.damping
    tau = m / b
    assert state.velocity == pytest.approx(force / b * (1.0 - math.exp(-t / tau)), rel=0.005)
    assert state.position == pytest.approx(force / b * (t - tau * (1.0 - math.exp(-t / tau))), rel=0.03)


def test_the_commanded_force_is_saturated_at_20_newtons_keeping_its_direction():
    device = HapticDevice()
    command = np.array([60.0, 80.0, 0.0])              # 100 N
    assert np.linalg.norm(device.saturate(command)) == pytest.approx(20.0)
    assert device.saturate(command) == pytest.approx([12.0, 16.0, 0.0])
    state = device.step(command, np.zeros(3), 0.002)
    assert np.linalg.norm(state.velocity) == pytest.approx(20.0 / PARAMETERS.mass * 0.002, rel=0.01)
    # The hand is not saturated: a 30 N push is felt whole.
    device = HapticDevice()
    state = device.step(np.zeros(3), np.array([30.0, 0.0, 0.0]), 0.002)
    assert state.velocity[0] == pytest.approx(30.0 / PARAMETERS.mass * 0.002, rel=0.01)


def test_a_force_command_moves_the_handle_and_damping_stops_it():
    device = HapticDevice()
    device.step([1.0, 0.0, 0.0], np.zeros(3), 0.05)
    moving = device.state
    assert moving.velocity[0] > 0.09 and moving.position[0] > 0.002
    for _ in range(1000):                               # 5 s free: viscous damping brings it to rest
        device.step(np.zeros(3), np.zeros(3), 0.005)
    assert abs(device.velocity[0]) < 1e-3
    assert device.position[0] > moving.position[0]


def test_a_spring_force_command_makes_the_handle_settle_at_the_spring_origin():
    # The closed haptic loop: each 2 ms (the node's 500 Hz) the force is recomputed from the state it caused.
    device = HapticDevice(position=[0.05, -0.03, 0.02])
    stiffness, damping = 200.0, 10.0
    for _ in range(2000):                               # 4 s
        command = -stiffness * device.position - damping * device.velocity
        device.step(command, np.zeros(3), 0.002)
    assert np.linalg.norm(device.position) < 1e-4 and np.linalg.norm(device.velocity) < 1e-3


def test_an_undamped_spring_neither_gains_nor_loses_much_energy():
    # Semi-implicit Euler keeps an oscillator's energy bounded (explicit Euler would grow it every cycle).
    device = HapticDevice(HapticDeviceParameters(damping=0.0), position=[0.05, 0.0, 0.0])
    stiffness = 100.0
    energies = []
    for _ in range(5000):                               # 5 s, about 11 periods
        device.step(-stiffness * device.position, np.zeros(3), 0.001)
        energies.append(0.5 * PARAMETERS.mass * device.velocity @ device.velocity
                        + 0.5 * stiffness * device.position @ device.position)
    initial = 0.5 * stiffness * 0.05 ** 2
    assert max(energies) < 1.02 * initial and min(energies) > 0.95 * initial


def test_soft_walls_hold_the_handle_inside_the_workspace():
    device = HapticDevice()
    # The motors at full force (20 N) push diagonally outward for 3 s.
    for _ in range(1500):
        device.step([20.0, 20.0, -20.0], np.zeros(3), 0.002)
    penetration = np.abs(device.position) - np.array(PARAMETERS.half_extents)
    # 20 N / sqrt(3) per axis on a 5000 N/m wall: about 2.3 mm beyond the box, and at rest there.
    assert np.all(penetration > 0.0) and np.all(penetration < 0.004)
    assert np.linalg.norm(device.velocity) < 1e-3
    assert device.inside_workspace(margin=0.004) and not device.inside_workspace()


def test_the_wall_does_not_stick():
    device = HapticDevice(position=[0.1, 0.0, 0.0])     # 5 mm into the +x wall, at rest
    for _ in range(100):
        device.step(np.zeros(3), np.zeros(3), 0.002)
    assert device.position[0] < PARAMETERS.half_extents[0]      # pushed back inside
    assert device.velocity[0] < 0.0                             # and left moving inward, not held


def test_uneven_step_sizes_keep_exact_time():
    device_a, device_b = HapticDevice(), HapticDevice()
    for _ in range(300):
        device_a.step([1.0, 0.0, 0.0], np.zeros(3), 0.0025)     # 2.5 substeps per call
    for _ in range(750):
        device_b.step([1.0, 0.0, 0.0], np.zeros(3), 0.001)
    assert device_a.position == pytest.approx(device_b.position, rel=1e-9)


def test_a_hand_force_callable_is_evaluated_every_substep():
    calls = []

    def hand(position, velocity):
        calls.append(position.copy())
        return -300.0 * position

    device = HapticDevice(position=[0.01, 0.0, 0.0])
    device.step(np.zeros(3), hand, 0.005)
    assert len(calls) == 5 and calls[1][0] < calls[0][0]


def test_bad_input_is_refused():
    device = HapticDevice()
    with pytest.raises(FicInputError, match="command_force"):
        device.step([math.nan, 0.0, 0.0], np.zeros(3), 0.001)
    with pytest.raises(FicInputError, match="hand_force"):
        device.step(np.zeros(3), [0.0, 0.0], 0.001)
    with pytest.raises(FicInputError, match="dt"):
        device.step(np.zeros(3), np.zeros(3), -0.001)
    with pytest.raises(FicInputError, match="wall_stiffness"):
        HapticDeviceParameters(wall_stiffness=1e7)
    with pytest.raises(FicInputError, match="mass"):
        HapticDeviceParameters(mass=0.0)
    assert np.all(device.position == 0.0)
