"""Time-domain passivity at a delayed channel's ports (fic_core.channel_passivity_observer, passivity_controller).

The known loop is a position-force teleoperator through a channel of T = 1 s each way: a handle (0.5 kg) sends its
position, a replica (4 kg) follows it on a spring K = 200 N/m and sends back the spring's reaction, which the
handle feels T later; each mass has a light damping of 2 N s/m. Without passivity control this loop gains energy
(its loop gain K through 2 s of delay is far above what 2 N s/m can absorb: the damping margin of Lee and Spong is
about K T = 200 N s/m); with the observer and the controllers at both ports the channel lets out no more than it
was given and the loop settles.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_core.channel_passivity_observer import ChannelPortObserver
from fic_core.errors import FicInputError
from fic_core.passivity_controller import ForcePortPassivityController, MotionPortPassivityController

DT, DELAY = 0.001, 1.0
HANDLE_MASS, REPLICA_MASS, COUPLING, DAMPING = 0.5, 4.0, 200.0, 2.0


def position_force_loop(passivity_control: bool, duration: float = 30.0) -> dict[str, np.ndarray]:
    """Semi-implicit Euler of the module docstring's loop; the hand pushes the handle with 2 N for 0.5 s."""
    steps, lag = int(round(duration / DT)), int(round(DELAY / DT))
    master = ForcePortPassivityController(enabled=passivity_control)
    replica = MotionPortPassivityController(max_correction=0.01, enabled=passivity_control)
    x_m = v_m = x_r = v_r = 0.0
    forward: list[tuple[float, float]] = []     # (x_M, E_in of the master port) as sent
    backward: list[tuple[float, float]] = []    # (F, E_in of the replica port) as sent
    sent_force = 0.0
    log = {name: np.zeros(steps) for name in ("energy", "master_w", "replica_w", "damping", "gain")}
    for k in range(steps):
        # Replica side: the channel delivers x_M one delay ago (and the master's E_in with it).
        received, master_input = forward[k - lag] if k >= lag else (0.0, 0.0)
        replica.observer.receive(master_input)
        desired = float(replica.step([received], [sent_force], DT if k else 0.0)[0])
        coupling = COUPLING * (desired - x_r)
        sent_force = -coupling                        # the replica's reaction, sent back
        backward.append((sent_force, replica.observer.input_energy))
        # Master side: the channel delivers the replica's force one delay ago.
        force, replica_input = backward[k - lag] if k >= lag else (0.0, 0.0)
        master.observer.receive(replica_input)
        rendered = float(master.step([force], [v_m], DT)[0])
        forward.append((x_m, master.observer.input_energy))
        hand = 2.0 if 0.5 <= k * DT < 1.0 else 0.0
        v_m += (rendered - DAMPING * v_m + hand) / HANDLE_MASS * DT
        v_r += (coupling - DAMPING * v_r) / REPLICA_MASS * DT
        x_m += v_m * DT
        x_r += v_r * DT
        log["energy"][k] = 0.5 * HANDLE_MASS * v_m ** 2 + 0.5 * REPLICA_MASS * v_r ** 2 + \
            0.5 * COUPLING * (desired - x_r) ** 2
        log["master_w"][k], log["replica_w"][k] = master.observer.energy, replica.observer.energy
        log["damping"][k], log["gain"][k] = master.damping, replica.gain
    return log


@pytest.fixture(scope="module")
def without() -> dict[str, np.ndarray]:
    return position_force_loop(passivity_control=False)


@pytest.fixture(scope="module")
def with_control() -> dict[str, np.ndarray]:
    return position_force_loop(passivity_control=True)


def test_without_passivity_control_the_loop_gains_energy_and_the_observers_go_negative(without) -> None:
    assert without["damping"].max() == 0.0 and without["gain"].max() == 0.0   # the observers only watched
    energy = without["energy"]
    assert energy[-5000:].max() > 10 * energy[1000:2000].max()
    assert min(without["master_w"].min(), without["replica_w"].min()) < -0.1


def test_with_passivity_control_the_observers_stay_non_negative_and_the_loop_settles(with_control) -> None:
    assert with_control["master_w"].min() >= -1e-9
    assert with_control["replica_w"].min() >= -1e-9
    energy = with_control["energy"]
    assert energy[-5000:].max() < energy[:5000].max()
    assert with_control["damping"].max() > 0.0     # it had something to do


def test_the_damper_is_zero_while_the_observer_is_positive(with_control) -> None:
    """A tick's damping is there only when the tick would have taken W below zero: after it, W is zero."""
    for name, gain in (("master_w", "damping"), ("replica_w", "gain")):
        acting = with_control[gain] > 0.0
        assert np.all(np.abs(with_control[name][acting]) < 1e-9)


def test_the_damper_takes_out_exactly_the_deficit() -> None:
    controller = ForcePortPassivityController()
    controller.observer.receive(0.5)
    # 1 N along 1 m/s for 1 s lets 1 J out of a channel that was given 0.5 J: alpha = 0.5 N s/m.
    rendered = controller.step([1.0, 0.0], [1.0, 0.0], 1.0)
    assert controller.damping == pytest.approx(0.5)
    np.testing.assert_allclose(rendered, [0.5, 0.0])
    assert controller.observer.energy == pytest.approx(0.0, abs=1e-12)
    # Energy going in (the force against the motion) is never damped.
    assert np.all(controller.step([-1.0, 0.0], [1.0, 0.0], 1.0) == [-1.0, 0.0]) and controller.damping == 0.0


def test_the_motion_port_correction_is_bounded_and_keeps_the_rest_of_the_deficit() -> None:
    controller = MotionPortPassivityController(max_correction=1e-3)
    controller.step([0.0], [0.0], 0.0)
    delivered = controller.step([0.1], [-10.0], 0.01)   # 1 J out, nothing received: would need 0.1 m back
    assert delivered[0] == pytest.approx(0.1 - 1e-3)
    assert controller.drift[0] == pytest.approx(-1e-3)
    assert controller.observer.energy < -0.9 and controller.observer.negative_ticks == 1


def test_observer_bookkeeping_and_bad_input() -> None:
    observer = ChannelPortObserver()
    observer.receive(2.0)
    observer.receive(1.0)                   # a late, older figure does not lower it
    assert observer.received_input_energy == 2.0
    assert observer.observe(3.0, 1.0) == 2.0 and observer.input_energy == 3.0
    assert observer.observe(-2.5, 1.0) == pytest.approx(-0.5) and observer.min_energy == pytest.approx(-0.5)
    with pytest.raises(FicInputError):
        observer.observe(math.nan, 0.001)
    with pytest.raises(FicInputError):
        observer.receive(-1.0)
    with pytest.raises(FicInputError):
        ForcePortPassivityController().step([1.0, 0.0], [1.0], 0.001)


def written_out_force_port(forces, velocities, received, dt, max_damping):
    """The force port's damper tick by tick, written out from its definition (module docstring of
    fic_core.passivity_controller, Ryu and Hannaford's time-domain passivity): P = -F v into the channel; a tick
    that lets energy out and would take W = E_in,other - E_out below zero is damped by alpha = min(deficit, what
    the tick lets out) / (dt |v|^2), at most ``max_damping``; the damped force's power is booked."""
    output_energy = 0.0
    rendered, dampings, energies = [], [], []
    for force, velocity, other_input in zip(forces, velocities, received):
        power = -force * velocity
        let_out = max(-power, 0.0) * dt
        deficit = -(other_input - output_energy - let_out)
        needed = min(deficit, let_out) / dt if power < 0.0 and deficit > 0.0 else 0.0
        alpha = min(needed / velocity ** 2, max_damping) if needed > 0.0 and velocity ** 2 > 1e-18 else 0.0
        damped = force - alpha * velocity
        output_energy += max(damped * velocity, 0.0) * dt
        rendered.append(damped)
        dampings.append(alpha)
        energies.append(other_input - output_energy)
    return np.array(rendered), np.array(dampings), np.array(energies)


def written_out_motion_port(offsets, forces, received, dt, max_correction):
    """The motion port's correction, written out likewise: P = F v with v the received offset's rate; the
    delivered rate v + beta F with beta = min(deficit, what the tick lets out) / (dt |F|^2), scaled down so
    that |beta F dt| <= ``max_correction``; the delivered offset is the sum of the delivered rates."""
    output_energy = 0.0
    delivered = [offsets[0]]
    gains, energies = [0.0], [received[0]]
    for k in range(1, len(offsets)):
        velocity = (offsets[k] - offsets[k - 1]) / dt
        force = forces[k]
        power = force * velocity
        let_out = max(-power, 0.0) * dt
        deficit = -(received[k] - output_energy - let_out)
        needed = min(deficit, let_out) / dt if power < 0.0 and deficit > 0.0 else 0.0
        beta = needed / force ** 2 if needed > 0.0 and force ** 2 > 1e-18 else 0.0
        if beta * dt * abs(force) > max_correction:
            beta = max_correction / (dt * abs(force))
        rate = velocity + beta * force
        output_energy += max(-force * rate, 0.0) * dt
        delivered.append(delivered[-1] + rate * dt)
        gains.append(beta)
        energies.append(received[k] - output_energy)
    return np.array(delivered), np.array(gains), np.array(energies)


def test_the_force_port_damper_follows_its_written_out_law_with_a_bounded_damping() -> None:
    """Random ticks against the written-out law, with a damping bound that leaves deficits behind: the next
    ticks take out at most what each lets out (the force is damped to zero at most, never reversed against the
    motion to pay for an older deficit)."""
    rng = np.random.default_rng(3)
    steps, dt, bound = 3000, 0.001, 2.0
    forces = rng.normal(scale=3.0, size=steps)
    velocities = rng.normal(scale=0.2, size=steps)
    received = np.cumsum(rng.uniform(0.0, 2e-4, size=steps))   # the other side's E_in, never decreasing
    controller = ForcePortPassivityController(max_damping=bound)
    rendered, dampings = [], []
    for force, velocity, other_input in zip(forces, velocities, received):
        controller.observer.receive(other_input)
        rendered.append(float(controller.step([force], [velocity], dt)[0]))
        dampings.append(controller.damping)
    expected, expected_damping, expected_energy = written_out_force_port(forces, velocities, received, dt, bound)
    assert np.any(expected_damping == bound) and np.any((expected_damping > 0.0) & (expected_damping < bound))
    np.testing.assert_allclose(rendered, expected, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(dampings, expected_damping, rtol=1e-9, atol=1e-12)
    assert controller.observer.energy == pytest.approx(expected_energy[-1], abs=1e-12)
    # Damped toward zero, never past it: |F'| <= |F| and F' F >= 0 on every tick.
    assert np.all(np.abs(rendered) <= np.abs(forces) + 1e-12) and np.all(np.array(rendered) * forces >= -1e-12)


def test_the_motion_port_correction_follows_its_written_out_law() -> None:
    rng = np.random.default_rng(4)
    steps, dt, bound = 3000, 0.001, 2e-5
    offsets = np.cumsum(rng.normal(scale=1e-3, size=steps))
    forces = rng.normal(scale=5.0, size=steps)
    received = np.cumsum(rng.uniform(0.0, 1e-4, size=steps))
    controller = MotionPortPassivityController(max_correction=bound)
    delivered, gains = [], []
    for k in range(steps):
        controller.observer.receive(received[k])
        delivered.append(float(controller.step([offsets[k]], [forces[k]], dt if k else 0.0)[0]))
        gains.append(controller.gain)
    expected, expected_gain, expected_energy = written_out_motion_port(offsets, forces, received, dt, bound)
    corrections = expected_gain * dt * np.abs(forces)
    assert np.any(np.isclose(corrections, bound)) and np.any((corrections > 0.0) & (corrections < 0.99 * bound))
    np.testing.assert_allclose(delivered, expected, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(gains, expected_gain, rtol=1e-9, atol=1e-15)
    assert controller.observer.energy == pytest.approx(expected_energy[-1], abs=1e-12)


def test_a_disabled_motion_port_delivers_a_new_offset_even_at_the_same_instant() -> None:
    """Disabled, the controller passes the offset through unchanged, also on a repeat at the same instant (dt = 0);
    enabled, a repeat at the same instant books nothing and keeps what it delivered."""
    disabled = MotionPortPassivityController(0.01, enabled=False)
    disabled.step([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 0.0)
    np.testing.assert_array_equal(disabled.step([0.1, 0.0, 0.0], [1.0, 0.0, 0.0], 0.0), [0.1, 0.0, 0.0])
    enabled = MotionPortPassivityController(0.01, enabled=True)
    enabled.step([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 0.0)
    np.testing.assert_array_equal(enabled.step([0.1, 0.0, 0.0], [1.0, 0.0, 0.0], 0.0), [0.0, 0.0, 0.0])
