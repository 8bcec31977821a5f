"""The energy-and-motion verdict (fic_teleop_experiments.energy_verdict) on loops whose answer is known.

The reference loop is a position-position bilateral teleoperator: a handle (m_M = 0.5 kg) and a replica
(m_R = 4 kg) coupled by springs K on each other's DELAYED position, each with local damping B:

    m_M x_M'' = K (x_R(t - T) - x_M) - B x_M' + f_hand(t)
    m_R x_R'' = K (x_M(t - T) - x_R) - B x_R'

Without damping this loop is unstable for any delay (Anderson and Spong 1989); with the damping margin of
Lee and Spong 2006 ("Passive bilateral teleoperation with constant time delay", IEEE T-RO 22(2)),
B > (T_forward + T_backward)/2 * K, it is stable. At T = 1 s each way and K = 200 N/m the margin is 200 N s/m.
The energy is the two masses' kinetic energy plus the coupling springs' potential energy.

The same loop driven by a task (``lap_loop``): the operator's hand, a spring-damper, pulls the handle towards a
target that repeats every 5 s (E1's lap: an avoidance move of 30 mm on every lap). With the damping margin the loop
stays stable and its answer to the lap -- the handle giving way, the replica lagging its delayed command --
repeats at the lap: the motion test without the task's period takes that for a sustained oscillation (the defect
the lap median removes); with too little damping an oscillation at the loop's own period grows on top of the lap.
"""
from __future__ import annotations

import numpy as np
import pytest

from fic_teleop_experiments.energy_verdict import (EnergyMotionCriterion, VerdictInputError, assess_energy_motion)

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


LAP_S = 5.0
HAND_STIFFNESS, HAND_DAMPING = 300.0, 10.0


def lap_target(t: np.ndarray) -> np.ndarray:
    """The hand's target: from 2 s on, a raised-cosine move of 30 mm and back in 1.5 s on every 5 s lap."""
    phase = t % LAP_S
    bump = np.where((phase >= 1.0) & (phase < 2.5), 0.5 * (1.0 - np.cos(2.0 * np.pi * (phase - 1.0) / 1.5)), 0.0)
    return 0.03 * bump * (t >= 2.0)


def lap_loop(damping: float, delay: float, duration: float = 30.0):
    """The loop of the module docstring driven by the hand on ``lap_target``; (t, energy, motion) on a 10 ms grid,
    x_M judged against the hand's target and x_R against that target one delay later (the commanded motion, as
    evidence_run removes it). The energy adds the hand's spring to the masses' and the coupling's."""
    steps, lag = int(round(duration / DT)), int(round(delay / DT))
    t = np.arange(steps) * DT
    goal = lap_target(t)
    x_master, x_replica, energy = np.zeros(steps), np.zeros(steps), np.zeros(steps)
    position, velocity = np.zeros(2), np.zeros(2)
    mass = np.array([HANDLE_MASS, REPLICA_MASS])
    for k in range(steps):
        x_master[k], x_replica[k] = position
        seen_replica = x_replica[k - lag] if k >= lag else 0.0
        seen_master = x_master[k - lag] if k >= lag else 0.0
        hand = HAND_STIFFNESS * (goal[k] - position[0]) - HAND_DAMPING * velocity[0]
        force = np.array([COUPLING * (seen_replica - position[0]) + hand,
                          COUPLING * (seen_master - position[1])]) - damping * velocity
        velocity = velocity + force / mass * DT
        position = position + velocity * DT
        squares = (seen_replica - position[0]) ** 2 + (seen_master - position[1]) ** 2
        energy[k] = (0.5 * float(mass @ velocity ** 2) + 0.5 * COUPLING * squares
                     + 0.5 * HAND_STIFFNESS * (goal[k] - position[0]) ** 2)
    commanded = np.interp(t - delay, t, goal)
    zero = 0.0 * t
    motion = {"x_M": np.column_stack([x_master - goal, zero, zero]),
              "x_R": np.column_stack([x_replica - commanded, zero, zero])}
    grid = slice(None, None, 10)
    return t[grid], energy[grid], {name: values[grid] for name, values in motion.items()}


@pytest.mark.parametrize("delay", [1.0, 2.0])
def test_delayed_position_position_without_damping_is_unstable(delay: float):
    t, energy, motion = bilateral(damping=2.0, delay=delay)
    assert energy[-1000:].max() > 10 * energy[2000:3000].max()   # the model itself gains energy (sanity)
    verdict = assess_energy_motion(t, energy=energy, motion=motion,
                                   criterion=EnergyMotionCriterion(round_trip_delay=2.0 * delay))
    assert verdict.assessed and verdict.stable is False
    assert any("energy growing" in reason or "above the bound" in reason for reason in verdict.reasons)


@pytest.mark.parametrize("delay", [1.0, 2.0])
def test_the_same_loop_with_the_damping_margin_is_stable(delay: float):
    """At 2 s the 30 s run holds less than two 16 s windows: they overlap (by 3 s) and the run is still judged."""
    t, energy, motion = bilateral(damping=1.5 * COUPLING * delay, delay=delay)
    verdict = assess_energy_motion(t, energy=energy, motion=motion,
                                   criterion=EnergyMotionCriterion(round_trip_delay=2.0 * delay))
    assert verdict.assessed and verdict.stable is True, verdict.reasons
    assert verdict.windows_overlap == pytest.approx(0.0 if delay == 1.0 else 3.0, abs=0.02)


@pytest.mark.parametrize("delay", [1.0, 2.0])
def test_a_stable_loop_driven_by_the_lap_is_stable(delay: float):
    """The damping margin's loop on the 5 s lap at 1 and 2 s: energy flat, its answer to the lap 15-17 mm and
    periodic at the lap. Judged without the task's period (the criterion before the lap median) that is a
    'sustained oscillation'; with it, what is left differs from lap to lap by under 1 mm, and the loop is stable."""
    t, energy, motion = lap_loop(damping=1.5 * COUPLING * delay, delay=delay)
    before = assess_energy_motion(t, energy=energy, motion=motion,
                                  criterion=EnergyMotionCriterion(round_trip_delay=2.0 * delay))
    assert before.assessed and before.stable is False
    assert before.energy_growth < 2.0 and not any("energy" in reason for reason in before.reasons)
    assert before.signals["x_M"].period == pytest.approx(LAP_S, abs=0.1)
    assert any("sustained oscillation of x_M" in reason for reason in before.reasons)
    verdict = assess_energy_motion(t, energy=energy, motion=motion,
                                   criterion=EnergyMotionCriterion(round_trip_delay=2.0 * delay, task_period=LAP_S))
    assert verdict.assessed and verdict.stable is True, verdict.reasons
    assert max(max(signal.amplitude) for signal in verdict.signals.values()) < 0.002
    assert verdict.laps_in_lap_median * LAP_S == pytest.approx(22.0 if delay == 1.0 else 20.0, abs=0.05)


def test_a_growing_oscillation_riding_on_the_lap_is_unstable():
    """Damping 3 N s/m at 1 s (the margin is 200): the loop's own oscillation (period about 3.1 s, 1.6 round trips)
    grows on top of the lap. Both the energy and the lap-to-lap motion say so."""
    t, energy, motion = lap_loop(damping=3.0, delay=1.0)
    assert energy[t >= 25.0].max() > 3.0 * energy[(t >= 10.0) & (t < 15.0)].max()   # the model grows (sanity)
    verdict = assess_energy_motion(t, energy=energy, motion=motion,
                                   criterion=EnergyMotionCriterion(round_trip_delay=2.0, task_period=LAP_S))
    assert verdict.assessed and verdict.stable is False
    assert any("energy growing" in reason for reason in verdict.reasons)
    assert any("sustained oscillation of x_M (lap-to-lap motion)" in reason for reason in verdict.reasons)
    assert verdict.signals["x_M"].period == pytest.approx(3.15, abs=0.15)


def test_a_growing_oscillation_on_the_lap_with_flat_energy_is_caught_by_the_motion():
    """The stable lap loop's motion plus an oscillation at 3.3 s (not a multiple of the lap's frequency) growing from
    4 to 18 mm, with the stable loop's flat energy: only the motion test can tell, and it does."""
    t, energy, motion = lap_loop(damping=1.5 * COUPLING, delay=1.0)
    growing = 0.004 * np.exp(t / 20.0) * np.sin(2.0 * np.pi * t / 3.3)
    motion["x_R"] = motion["x_R"] + np.column_stack([growing, 0.0 * t, 0.0 * t])
    verdict = assess_energy_motion(t, energy=energy, motion=motion,
                                   criterion=EnergyMotionCriterion(round_trip_delay=2.0, task_period=LAP_S))
    assert verdict.stable is False and verdict.energy_growth < 2.0
    assert any("sustained oscillation of x_R (lap-to-lap motion)" in reason for reason in verdict.reasons)
    assert verdict.signals["x_R"].period == pytest.approx(3.3, abs=0.1)


@pytest.mark.parametrize("task_period", [None, LAP_S])
def test_a_limit_cycle_that_does_not_grow_is_unstable(task_period: float | None):
    """Constant energy, constant amplitude: test 1 passes, the motion test must not. Period 7 s = 3.5 round trips;
    with the task's 5 s lap as well (on the lap's typical (median) motion, which the lap median takes away)."""
    t = np.arange(0.0, 30.0, 0.01)
    swing = 0.02 * np.sin(2 * np.pi * t / 7.0) + (0.0 if task_period is None else lap_target(t))
    motion = {"x_R": np.column_stack([swing, 0 * t, 0 * t])}
    energy = np.full(t.size, 0.01)
    verdict = assess_energy_motion(t, energy=energy, motion=motion,
                                   criterion=EnergyMotionCriterion(round_trip_delay=2.0, task_period=task_period))
    assert verdict.stable is False
    assert any("sustained oscillation of x_R" in reason for reason in verdict.reasons)
    assert verdict.signals["x_R"].period == pytest.approx(7.0, abs=0.1 if task_period is None else 0.35)


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


@pytest.mark.parametrize("seed", [0, 3, 4])
def test_a_slow_wander_with_a_ripple_is_not_a_period(seed: int):
    """12 mm of aperiodic wander (seeded noise smoothed over 1.5 s) with a 0.6 mm, 4 Hz ripple, 7-10 mm in every
    16 s window: the autocorrelation stays near 1 at short lags and the ripple puts local maxima on it (0.21-0.24 s,
    0.98-1.00 for these seeds, which the test took for a period before it asked for a fall to zero first)."""
    t = np.arange(0.0, 30.0, 0.01)
    noise = np.random.default_rng(seed).standard_normal(t.size + 2000)
    smoothed = np.convolve(noise, np.exp(-0.5 * (np.arange(-1000, 1001) * 0.01 / 1.5) ** 2), mode="valid")[:t.size]
    wander = 0.012 * smoothed / np.abs(smoothed).max() + 0.0006 * np.sin(2 * np.pi * 4.0 * t)
    verdict = assess_energy_motion(t, energy=np.full(t.size, 1e-3), motion={"x_R": wander},
                                   criterion=EnergyMotionCriterion(round_trip_delay=4.0))
    assert min(verdict.signals["x_R"].amplitude) > 0.005   # large enough: only periodicity decides
    assert verdict.stable is True, verdict.reasons
    assert verdict.signals["x_R"].periodicity < 0.5


def test_too_short_a_run_is_not_assessed():
    """At 1 s each way the windows are 8 s: 1 s of settling and 1.5 windows need 13 s; the lap median over 2 laps after
    one lap and one round trip needs 18 s."""
    for duration, task_period, assessed in ((10.0, None, False), (13.5, None, True), (13.5, LAP_S, False),
                                            (18.5, LAP_S, True)):
        t = np.arange(0.0, duration, 0.01)
        verdict = assess_energy_motion(t, energy=np.zeros(t.size), motion={"x_R": np.zeros(t.size)},
                                       criterion=EnergyMotionCriterion(round_trip_delay=2.0, task_period=task_period))
        assert verdict.assessed is assessed, (duration, task_period, verdict.reasons)
        assert verdict.stable is (True if assessed else None)


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

