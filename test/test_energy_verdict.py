"""The energy-and-motion verdict (sim_bridge.experiments.energy_verdict) on loops whose answer is known.

The reference loop is a position-position bilateral teleoperator: a handle (m_M = 0.5 kg) and a replica
(m_R = 4 kg) coupled by springs K on each other's DELAYED position, each with local damping B:

    m_M x_M'' = K (x_R(t - T) - x_M) - B x_M' + f_hand(t)
    m_R x_R'' = K (x_M(t - T) - x_R) - B x_R'

Without damping this loop is unstable for any delay (Anderson and Spong 1989); with the damping margin of
Lee and Spong 2006 ("Passive bilateral teleoperation with constant time delay", IEEE T-RO 22(2)),
B > (T_forward + T_backward)/2 * K, it is stable. At T = 1 s each way and K = 200 N/m the margin is 200 N s/m.
The energy is the two masses' kinetic energy plus the coupling springs' potential energy.
"""
from __future__ import annotations

import numpy as np
import pytest

from sim_bridge.experiments.energy_verdict import (EnergyMotionCriterion, VerdictInputError, assess_energy_motion)

DT = 0.001
HANDLE_MASS, REPLICA_MASS, COUPLING = 0.5, 4.0, 200.0


def bilateral(damping: float, delay: float, duration: float = 30.0, ports: bool = False):
    """Semi-implicit Euler of the loop above; the operator pushes the handle with 2 N for 0.5 s, then lets go.
    ``ports``: also the energy the delayed coupling generated so far, the coupling forces' work on the two masses
    minus the coupling's storage (the two delayed springs hold K/4 of their squares each: one spring K without
    delay)."""
    steps, lag = int(round(duration / DT)), int(round(delay / DT))
    t = np.arange(steps) * DT
    x_master, x_replica = np.zeros(steps), np.zeros(steps)
    position, velocity = np.zeros(2), np.zeros(2)
    energy, generated = np.zeros(steps), np.zeros(steps)
    work = 0.0
    mass = np.array([HANDLE_MASS, REPLICA_MASS])
    for k in range(steps):
        x_master[k], x_replica[k] = position
        seen_replica = x_replica[k - lag] if k >= lag else 0.0
        seen_master = x_master[k - lag] if k >= lag else 0.0
        hand = 2.0 if 0.5 <= t[k] < 1.0 else 0.0
        force = np.array([COUPLING * (seen_replica - position[0]) + hand,
                          COUPLING * (seen_master - position[1])]) - damping * velocity
        coupling = np.array([COUPLING * (seen_replica - position[0]), COUPLING * (seen_master - position[1])])
        velocity = velocity + force / mass * DT
        position = position + velocity * DT
        work += float(coupling @ velocity) * DT
        squares = (seen_replica - position[0]) ** 2 + (seen_master - position[1]) ** 2
        energy[k] = 0.5 * float(mass @ velocity ** 2) + 0.5 * COUPLING * squares
        # The two delayed springs are one spring K without delay: each holds half of it, K/4 of its square.
        generated[k] = work - 0.25 * COUPLING * squares
    motion = {"x_M": np.column_stack([x_master, 0 * t, 0 * t]), "x_R": np.column_stack([x_replica, 0 * t, 0 * t])}
    return (t, energy, motion, generated) if ports else (t, energy, motion)


def test_delayed_position_position_without_damping_is_unstable():
    t, energy, motion = bilateral(damping=2.0, delay=1.0)
    assert energy[-1000:].max() > 10 * energy[1000:2000].max()   # the model itself gains energy (sanity)
    verdict = assess_energy_motion(t, energy=energy, motion=motion,
                                   criterion=EnergyMotionCriterion(round_trip_delay=2.0))
    assert verdict.assessed and verdict.stable is False
    assert any("energy growing" in reason for reason in verdict.reasons)


def test_the_same_loop_with_the_damping_margin_is_stable():
    t, energy, motion = bilateral(damping=1.5 * COUPLING * 1.0, delay=1.0)
    verdict = assess_energy_motion(t, energy=energy, motion=motion,
                                   criterion=EnergyMotionCriterion(round_trip_delay=2.0))
    assert verdict.assessed and verdict.stable is True, verdict.reasons


def test_a_limit_cycle_that_does_not_grow_is_unstable():
    """Constant energy, constant amplitude: test 1 passes, the motion test must not. Period 7 s = 3.5 round trips."""
    t = np.arange(0.0, 30.0, 0.01)
    swing = 0.02 * np.sin(2 * np.pi * t / 7.0)
    motion = {"x_R": np.column_stack([swing, 0 * t, 0 * t])}
    energy = np.full(t.size, 0.01)
    verdict = assess_energy_motion(t, energy=energy, motion=motion,
                                   criterion=EnergyMotionCriterion(round_trip_delay=2.0))
    assert verdict.stable is False
    assert any("sustained oscillation of x_R" in reason for reason in verdict.reasons)
    assert verdict.signals["x_R"].period == pytest.approx(7.0, abs=0.1)


def test_an_operators_aperiodic_moves_are_not_oscillation():
    """Steps and ramps of 3 cm at irregular times (an operator's avoidance moves), no repetition."""
    t = np.arange(0.0, 30.0, 0.01)
    rng = np.random.default_rng(3)
    times = np.sort(rng.uniform(0.0, 30.0, 9))
    targets = rng.uniform(-0.03, 0.03, 9)
    x = np.zeros(t.size)
    for when, where in zip(times, targets):
        x = np.where(t >= when, x + (where - x) * (1 - np.exp(-(t - when) / 0.3)), x)
    verdict = assess_energy_motion(t, energy=np.full(t.size, 1e-3), motion={"x_M": x},
                                   criterion=EnergyMotionCriterion(round_trip_delay=2.0))
    assert verdict.stable is True, verdict.reasons


def test_too_short_a_run_is_not_assessed():
    t = np.arange(0.0, 10.0, 0.01)
    verdict = assess_energy_motion(t, energy=np.zeros(t.size), motion={"x_R": np.zeros(t.size)},
                                   criterion=EnergyMotionCriterion(round_trip_delay=2.0))
    assert not verdict.assessed and verdict.stable is None


def test_bad_input_is_refused():
    with pytest.raises(VerdictInputError):
        assess_energy_motion(np.array([0.0, 1.0, 1.0, 2.0] * 3), energy=np.zeros(12), motion={},
                             criterion=EnergyMotionCriterion(round_trip_delay=0.4))


def test_a_bounded_runaway_is_unstable_by_its_error():
    """Flat energy, no repetition, but the replica 0.3 m from its set point: the error bound (4 x_b) says no."""
    t = np.arange(0.0, 30.0, 0.01)
    error = np.column_stack([np.full(t.size, 0.3), 0 * t, 0 * t])
    verdict = assess_energy_motion(t, energy=np.full(t.size, 1.0), motion={"x_R": np.zeros(t.size)},
                                   criterion=EnergyMotionCriterion(round_trip_delay=0.4), error=error)
    assert verdict.stable is False and "tracking error 300 mm" in verdict.reasons[0]
    assert assess_energy_motion(t, energy=np.full(t.size, 1.0), motion={"x_R": np.zeros(t.size)},
                                criterion=EnergyMotionCriterion(round_trip_delay=0.4), error=error / 3).stable


def test_the_channels_generated_energy_tells_the_two_loops_apart():
    """Test 4 alone (flat energy and no motion given): the undamped loop's delay generates more every cycle, the
    loop with the damping margin's generation settles; both are reported."""
    for damping, stable in ((2.0, False), (1.5 * COUPLING * 1.0, True)):
        t, energy, motion, generated = bilateral(damping=damping, delay=1.0, ports=True)
        verdict = assess_energy_motion(t, energy=np.zeros(t.size), motion={}, channel_generated=generated,
                                       passivity_margin=np.zeros(t.size),
                                       criterion=EnergyMotionCriterion(round_trip_delay=2.0))
        assert verdict.stable is stable, (damping, verdict.reasons, verdict.ports)
        windows = verdict.ports["channel_generated_window_peaks_j"]
        assert len(windows) == 2 and verdict.ports["passivity_margin_min_j"] == 0.0
        if not stable:
            assert windows[-1] > 2.0 * windows[0] > 0.0
            assert any("generated energy growing" in reason for reason in verdict.reasons)
        # With the motion and energy as well, the verdict is the one the other tests give.
        assert assess_energy_motion(t, energy=energy, motion=motion, channel_generated=generated,
                                    criterion=EnergyMotionCriterion(round_trip_delay=2.0)).stable is stable

