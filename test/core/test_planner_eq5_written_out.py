"""Eq. 5's phase switch on d|x~_t|/dt (docs/CONTROL_LAWS.md), x~_t = x_t - x_d'': an axis in D enters C when the
magnitude of its error falls faster than the dead-band, and stays in C while it falls on the side it entered on.
The magnitude of a zero error has no rate to fall at, so a target landing exactly on x_d'' enters no axis into C,
whatever the target's and x_d'''s velocities, and an axis at rest on its target stays in D."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.attractor import Phase
from fic_core.errors import FicInputError
from fic_core.planner import HarmonicPlanner


def test_a_target_exactly_on_x_d_enters_no_axis_into_convergence() -> None:
    """The target runs away at 0.5 m/s (x_d'' chases it in D), then jumps back onto x_d''."""
    planner = HarmonicPlanner(8.0, 0.25)
    planner.reset(np.zeros(3))
    for k in range(1, 11):
        position = planner.step([0.005 * k, 0.0, 0.0], 0.01)
    assert planner.velocity[0] > 0.1 and planner.phase[0] == int(Phase.DIVERGENCE)
    planner.step(position.copy(), 0.01)   # x~_t = 0 on every axis
    assert planner.phase.tolist() == [int(Phase.DIVERGENCE)] * 3
    assert np.isfinite(planner.acceleration).all() and np.isfinite(planner.velocity).all()


def test_the_phase_switch_is_eq_5s_written_out() -> None:
    """Tick by tick along a 0.5 Hz sine target (5 cm on x, 2 cm on y) with a 0.05 m/s dead-band, the rate
    sign(x~_t) (x_t' - x_d''') from before the tick (x_t' the target's difference quotient, 0 on the first tick):
    an axis in D enters C exactly when the rate is below -0.05 m/s; an axis in C stays in C exactly while the rate
    is below 0 and x~_t is on the side of x~_T0, its error on the tick it entered."""
    dt, deadband = 0.01, 0.05
    planner = HarmonicPlanner(8.0, 0.25, rate_deadband=deadband)
    planner.reset(np.zeros(3))
    previous_target = None
    latched = np.zeros(3)
    entered = stayed_in_d = stayed_in_c = left_c = 0
    for k in range(400):
        target = np.array([0.05 * np.sin(np.pi * k * dt), 0.02 * np.cos(np.pi * k * dt), 0.0])
        position, velocity, phase = planner.position, planner.velocity, planner.phase
        error = target - position
        target_velocity = np.zeros(3) if previous_target is None else (target - previous_target) / dt
        rate = np.sign(error) * (target_velocity - velocity)
        planner.step(target, dt)
        for axis in range(3):
            in_c = planner.phase[axis] == int(Phase.CONVERGENCE)
            if phase[axis] == int(Phase.DIVERGENCE):
                enters = bool(rate[axis] < -deadband)
                assert in_c == enters, (k, axis, rate[axis])
                entered += enters
                stayed_in_d += not enters
                if enters:
                    latched[axis] = error[axis]
            else:
                stays = bool(rate[axis] < 0.0 and np.sign(error[axis]) == np.sign(latched[axis]))
                assert in_c == stays, (k, axis, rate[axis])
                stayed_in_c += stays
                left_c += not stays
        previous_target = target
    assert min(entered, left_c) >= 4 and min(stayed_in_d, stayed_in_c) >= 50, (entered, left_c, stayed_in_d,
                                                                               stayed_in_c)


def wave(k: int, dt: float) -> np.ndarray:
    return np.array([0.12 * np.sin(1.3 * k * dt), 0.04 * np.cos(2.1 * k * dt), 0.01 * k * dt])


def far(k: int, dt: float) -> np.ndarray:
    return np.array([2.0, -0.5, 0.0])


@pytest.mark.parametrize("natural_frequency, path", [(8.0, wave), (0.5, wave), (8.0, far), (0.5, far)])
def test_each_step_is_eqs_5_and_6_written_out(natural_frequency: float, path) -> None:
    """docs/CONTROL_LAWS.md's lines, per axis and tick, along a target that moves (every tick a new command, Eq. 6
    from the current x_d''): D: a = sign(x~_t) min(w_n^2 |x~_t|, a_max) - mu v; C: a = 2 A_max / |x~_T0| (x~_t -
    x~_T0 / 2) - mu v, A_max = min(w_n^2 |x~_T0|, a_max) when the axis entered C; a clipped to +-a_max, v's norm
    to v_d, x_d'' the sum of v dt. Eq. 6, for a target that moved (a new command): v_max = v_p min(v_d, w_n |d|),
    a_max = 2 |d| (v_max / |d|)^2. With w_n = 8 rad/s a_max binds most; with 0.5 rad/s the spring w_n^2 |x~_t|
    does; a fixed target 2 m away is one command and a long convergence."""
    dt, max_velocity, peak_ratio = 0.01, 0.25, 1.595
    viscosity = 0.01 * natural_frequency
    planner = HarmonicPlanner(natural_frequency, max_velocity, velocity_peak_ratio=peak_ratio)
    planner.reset(np.zeros(3))
    position, velocity = np.zeros(3), np.zeros(3)
    latched, latched_acceleration = np.zeros(3), np.zeros(3)
    in_c = np.zeros(3, dtype=bool)
    previous_target = command_target = None
    for k in range(300):
        target = path(k, dt)
        error = target - position
        if command_target is None or np.max(np.abs(target - command_target)) > 1e-9:
            distance = float(np.linalg.norm(error))
            peak = peak_ratio * min(max_velocity, natural_frequency * distance)
            max_acceleration = 2.0 * np.abs(error) * (peak / distance) ** 2
            command_target = target
        target_velocity = np.zeros(3) if previous_target is None else (target - previous_target) / dt
        rate = np.sign(error) * (target_velocity - velocity)
        staying = in_c & (rate < 0.0) & (np.sign(error) == np.sign(latched))
        entering = ~in_c & (rate < 0.0)
        latched = np.where(entering, error, latched)
        latched_acceleration = np.where(entering, np.minimum(natural_frequency ** 2 * np.abs(error),
                                                             max_acceleration), latched_acceleration)
        in_c = staying | entering
        divergence = np.sign(error) * np.minimum(natural_frequency ** 2 * np.abs(error), max_acceleration)
        safe = np.where(latched != 0.0, np.abs(latched), 1.0)
        convergence = 2.0 * latched_acceleration / safe * (error - 0.5 * latched)
        acceleration = np.clip(np.where(in_c, convergence, divergence) - viscosity * velocity, -max_acceleration,
                               max_acceleration)
        new_velocity = velocity + acceleration * dt
        speed = float(np.linalg.norm(new_velocity))
        if speed > max_velocity:
            new_velocity *= max_velocity / speed
        expected_acceleration = (new_velocity - velocity) / dt
        velocity = new_velocity
        position = position + velocity * dt
        planner.step(target, dt)
        np.testing.assert_allclose(planner.acceleration, expected_acceleration, rtol=1e-9, atol=1e-12, err_msg=k)
        np.testing.assert_allclose(planner.position, position, rtol=1e-9, atol=1e-15, err_msg=k)
        assert planner.phase.tolist() == np.where(in_c, int(Phase.CONVERGENCE), int(Phase.DIVERGENCE)).tolist(), k
        np.testing.assert_allclose(planner.max_acceleration, max_acceleration, rtol=1e-12, err_msg=k)
        previous_target = target


@pytest.mark.parametrize("dt", [0.0, -0.01])
def test_a_step_needs_time_to_pass(dt: float) -> None:
    planner = HarmonicPlanner(8.0, 0.25)
    with pytest.raises(FicInputError, match="dt"):
        planner.step([0.1, 0.0, 0.0], dt)
