"""The force-reactive hand (sim_bridge/device/reactive_hand.py): reflex after its latency, voluntary response after
its reaction time, co-contraction with the felt force, and the hand alone on the handle settles at every range end."""
from __future__ import annotations

import numpy as np
import pytest

from sim_bridge.device import reactive_hand as rh
from sim_bridge.device.haptic_device import HapticDevice, HapticDeviceParameters
from sim_bridge.device.reactive_hand import ReactiveHand, ReactiveHandParameters
from sim_bridge.device.virtual_operator import HandParameters

TICK = 0.004   # the device node's 250 Hz


def test_the_reflex_answers_a_stretch_one_latency_later_and_opposes_it() -> None:
    hand = ReactiveHand(HandParameters(correction_rate=0.0), ReactiveHandParameters(reflex_latency=0.04,
                                                                                     voluntary_reaction_time=0.2))
    stretched = np.array([0.01, 0.0, 0.0])
    forces = []
    for k in range(30):
        hand.update(np.zeros(3), stretched if k >= 5 else np.zeros(3), TICK)
        forces.append(hand.reflex_force[0])
    first = next(k for k, force in enumerate(forces) if force != 0.0)
    assert (first - 5) * TICK == pytest.approx(0.04)
    assert forces[-1] == pytest.approx(-hand.reactive.reflex_stiffness * 0.01)


def test_the_felt_force_stiffens_the_arm_after_the_reaction_time_and_no_sooner() -> None:
    hand = ReactiveHand(HandParameters(), ReactiveHandParameters(voluntary_reaction_time=0.2,
                                                                 cocontraction_per_newton=0.05))
    scales = []
    for k in range(100):
        hand.update(np.zeros(3), np.zeros(3), TICK, np.zeros(3), np.array([0.0, 10.0, 0.0]) if k >= 10 else None)
        scales.append(hand.cocontraction)
    first = next(k for k, scale in enumerate(scales) if scale > 0.0)
    assert (first - 10) * TICK == pytest.approx(0.2)
    assert scales[-1] == pytest.approx(0.5)
    np.testing.assert_allclose(hand.force(np.array([0.01, 0.0, 0.0]), np.zeros(3)), [-1.5 * 300.0 * 0.01, 0, 0])
    hand.update(np.zeros(3), np.zeros(3), TICK, np.zeros(3), np.array([0.0, 1000.0, 0.0]))
    for _ in range(60):
        hand.update(np.zeros(3), np.zeros(3), TICK, np.zeros(3), np.array([0.0, 1000.0, 0.0]))
    assert hand.cocontraction == hand.reactive.max_cocontraction


def test_the_voluntary_correction_waits_for_the_reaction_time() -> None:
    hand = ReactiveHand(HandParameters(), ReactiveHandParameters(voluntary_reaction_time=0.2))
    corrections = []
    for _ in range(80):
        hand.update(np.array([0.02, 0.0, 0.0]), np.zeros(3), TICK)
        corrections.append(hand.correction[0])
    first = next(k for k, c in enumerate(corrections) if c > 0.0)
    assert first * TICK == pytest.approx(0.2, abs=TICK)


def _extreme(ends: tuple[int, ...]) -> ReactiveHandParameters:
    ranges = (rh.REFLEX_LATENCY_RANGE_S, rh.REFLEX_STIFFNESS_FRACTION_RANGE, rh.REFLEX_DAMPING_FRACTION_RANGE,
              rh.VOLUNTARY_REACTION_TIME_RANGE_S, rh.VOLUNTARY_RATE_RANGE, rh.COCONTRACTION_PER_NEWTON_RANGE)
    latency, stiffness, damping, reaction, rate, cocontraction = (r[e] for r, e in zip(ranges, ends))
    return ReactiveHandParameters(latency, stiffness * 300.0, damping * 15.0, reaction, rate, cocontraction)


@pytest.mark.parametrize("ends", [(0, 0, 0, 0, 0, 0), (1, 1, 1, 1, 1, 1), (1, 1, 0, 1, 1, 1), (0, 1, 0, 1, 1, 1)])
def test_the_hand_alone_on_the_handle_settles_at_the_ranges_ends(ends) -> None:
    # A step of the target with a centring spring on the handle (the master's 100 N/m, saturated at 4 N) that the
    # hand feels: the handle reaches the target and stays there.
    hand = ReactiveHand(HandParameters(), _extreme(ends))
    device = HapticDevice(HapticDeviceParameters(mass=0.5, damping=2.0, half_extents=(0.095, 0.065, 0.065)))
    path = []
    for k in range(1500):
        target = np.array([0.03, -0.02, 0.01]) if k >= 25 else np.zeros(3)
        motor = np.clip(-100.0 * device.position, -4.0, 4.0)
        hand.update(target, device.position, TICK, device.velocity, motor)
        device.step(motor, hand.force, TICK)
        path.append(device.position.copy())
    path = np.array(path)
    np.testing.assert_allclose(path[-1], [0.03, -0.02, 0.01], atol=2e-4)
    left = np.linalg.norm(path - [0.03, -0.02, 0.01], axis=1)
    assert left[-250:].max() < 5e-4 and left[-1] <= left[-250]   # within 0.5 mm in the last second, still closing
    assert np.abs(path[:, 0]).max() < 0.03 * 1.3               # overshoot below 30 %


def test_a_seed_draws_each_figure_inside_its_range() -> None:
    for seed in range(20):
        p = ReactiveHandParameters.drawn(np.random.default_rng(seed), HandParameters())
        assert rh.REFLEX_LATENCY_RANGE_S[0] <= p.reflex_latency <= rh.REFLEX_LATENCY_RANGE_S[1]
        reaction = rh.VOLUNTARY_REACTION_TIME_RANGE_S
        assert reaction[0] <= p.voluntary_reaction_time <= reaction[1]
        assert 0.25 * 300 <= p.reflex_stiffness <= 0.40 * 300
    assert len({ReactiveHandParameters.drawn(np.random.default_rng(s), HandParameters()) for s in range(5)}) == 5


def test_bad_figures_are_refused() -> None:
    with pytest.raises(Exception, match="reflex_latency"):
        ReactiveHandParameters(reflex_latency=-0.01)
