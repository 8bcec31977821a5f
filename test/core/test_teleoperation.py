"""Teleoperation modes (paper Sec. II-C): offset x_d' = s_M*x_M, velocity x_d' += k_v*x_M*dt, bumpless switching."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.errors import FicInputError
from fic_core.teleoperation import TeleoperationCommandIntegrator, TeleoperationMode


def test_mode_values_match_the_message_constants() -> None:
    assert TeleoperationMode.OFFSET == 0 and TeleoperationMode.VELOCITY == 1


def test_offset_mode_is_scaled_handle_position() -> None:
    integrator = TeleoperationCommandIntegrator(workspace_scale=2.0, velocity_gain=1.0)
    np.testing.assert_allclose(integrator.update([0.01, -0.02, 0.03], 0.004), [0.02, -0.04, 0.06])
    np.testing.assert_allclose(integrator.desired_offset, [0.02, -0.04, 0.06])


def test_velocity_mode_integrates_the_handle_position() -> None:
    integrator = TeleoperationCommandIntegrator(workspace_scale=1.0, velocity_gain=2.0,
                                                mode=TeleoperationMode.VELOCITY, velocity_deadband=0.0)
    for _ in range(250):
        integrator.update([0.05, 0.0, -0.01], 0.004)
    np.testing.assert_allclose(integrator.desired_offset, [2.0 * 0.05 * 1.0, 0.0, 2.0 * -0.01 * 1.0])


def test_velocity_dead_band_stops_drift_and_is_continuous() -> None:
    integrator = TeleoperationCommandIntegrator(velocity_gain=1.0, mode=TeleoperationMode.VELOCITY,
                                                velocity_deadband=0.005)
    for _ in range(1000):
        integrator.update([0.003, -0.002, 0.001], 0.004)  # a resting hand, inside the dead-band
    np.testing.assert_array_equal(integrator.desired_offset, np.zeros(3))
    # Just outside, the command is k_v*(|x_M| - deadband) along x_M: small, not a jump to k_v*|x_M|.
    integrator.update([0.0051, 0.0, 0.0], 1.0)
    assert integrator.desired_offset[0] == pytest.approx(0.0001)


def test_offset_mode_follows_the_hand_after_a_switch() -> None:
    integrator = TeleoperationCommandIntegrator(workspace_scale=1.5, velocity_gain=1.0,
                                                mode=TeleoperationMode.VELOCITY, velocity_deadband=0.0)
    for _ in range(100):
        integrator.update([0.02, 0.0, 0.0], 0.01)
    at_switch = integrator.desired_offset
    integrator.set_mode(TeleoperationMode.OFFSET)
    np.testing.assert_allclose(integrator.update([0.02, 0.0, 0.0], 0.01), at_switch)
    np.testing.assert_allclose(integrator.update([0.03, 0.01, 0.0], 0.01), at_switch + 1.5 * np.array([0.01, 0.01,
                                                                                                       0.0]))


@settings(max_examples=60, deadline=None)
@given(switches=st.lists(st.tuples(st.integers(1, 30), st.sampled_from([0, 1])), min_size=1, max_size=12),
       workspace_scale=st.floats(0.2, 5.0), velocity_gain=st.floats(0.0, 5.0), seed=st.integers(0, 2 ** 31))
def test_mode_switches_never_make_the_offset_jump(switches, workspace_scale, velocity_gain, seed) -> None:
    """Over a smooth hand motion with random switches (and scale changes), x_d' moves at most what one step
    of the active mode allows: never a jump."""
    rng = np.random.default_rng(seed)
    integrator = TeleoperationCommandIntegrator(workspace_scale, velocity_gain)
    dt, speed = 0.004, 0.5  # the hand moves at most 0.5 m/s
    hand = rng.uniform(-0.05, 0.05, 3)
    previous = None
    for steps, mode in switches:
        integrator.set_mode(mode)
        if rng.random() < 0.3:
            integrator.workspace_scale = float(rng.uniform(0.2, 5.0))
        for _ in range(steps):
            step = rng.normal(size=3)
            hand = np.clip(hand + speed * dt * step / max(np.linalg.norm(step), 1e-12), -0.1, 0.1)
            offset = integrator.update(hand, dt)
            if previous is not None:
                allowed = max(5.0 * speed * dt, velocity_gain * np.linalg.norm(hand) * dt) * (1 + 1e-9) + 1e-12
                assert np.linalg.norm(offset - previous) <= allowed
            previous = offset


def test_reset_and_toggle() -> None:
    integrator = TeleoperationCommandIntegrator(velocity_gain=1.0)
    assert integrator.toggle_mode() == TeleoperationMode.VELOCITY
    integrator.update([0.1, 0.0, 0.0], 1.0)
    assert integrator.toggle_mode() == TeleoperationMode.OFFSET
    integrator.reset()
    np.testing.assert_array_equal(integrator.desired_offset, np.zeros(3))
    np.testing.assert_allclose(integrator.update([0.01, 0.0, 0.0], 0.004), [0.01, 0.0, 0.0])


def test_invalid_inputs_are_rejected() -> None:
    integrator = TeleoperationCommandIntegrator()
    with pytest.raises(FicInputError, match="handle_position"):
        integrator.update([math.nan, 0, 0], 0.004)
    with pytest.raises(FicInputError, match="dt"):
        integrator.update([0, 0, 0], math.inf)
    with pytest.raises(FicInputError, match="dt"):
        integrator.update([0, 0, 0], -0.001)
    with pytest.raises(FicInputError, match="mode"):
        integrator.set_mode(7)
    for name in ("workspace_scale", "velocity_gain", "velocity_deadband"):
        with pytest.raises(FicInputError, match=name):
            TeleoperationCommandIntegrator(**{name: math.nan})
    with pytest.raises(FicInputError, match="workspace_scale"):
        TeleoperationCommandIntegrator(workspace_scale=0.0)
    with pytest.raises(FicInputError, match="workspace_scale"):
        integrator.workspace_scale = math.inf
    with pytest.raises(FicInputError, match="velocity_gain"):
        integrator.velocity_gain = -1.0


@pytest.mark.parametrize("mode", [TeleoperationMode.OFFSET, TeleoperationMode.VELOCITY])
def test_a_hold_stills_x_d_and_engaging_again_re_anchors_without_a_jump(mode: TeleoperationMode) -> None:
    """Indexing: while held, x_d' stands still whatever the handle does; engaged again, x_d' continues from its
    held value and (offset mode) follows the handle's displacement from where it was at the release."""
    integrator = TeleoperationCommandIntegrator(workspace_scale=2.0, velocity_gain=1.0, mode=mode,
                                                velocity_deadband=0.0)
    for x in np.linspace(0.0, 0.03, 4):
        before = integrator.update([x, 0.0, 0.0], 0.01)
    integrator.hold(True)
    assert integrator.held
    for x in np.linspace(0.03, -0.04, 8):   # the handle brought back past the centre, x_d' still
        np.testing.assert_array_equal(integrator.update([x, 0.01, 0.0], 0.01), before)
        np.testing.assert_array_equal(integrator.goal_at(np.array([x, 0.0, 0.0])), before)
    integrator.hold(False)
    engaged = integrator.update([-0.04, 0.01, 0.0], 0.01)
    if mode == TeleoperationMode.OFFSET:
        np.testing.assert_allclose(engaged, before)     # no jump
        later = integrator.update([-0.03, 0.02, 0.0], 0.01)
        np.testing.assert_allclose(later, before + 2.0 * np.array([0.01, 0.01, 0.0]))  # s_M times since release
        np.testing.assert_allclose(integrator.goal_at(np.array([-0.02, 0.02, 0.0])),
                                   before + 2.0 * np.array([0.02, 0.01, 0.0]))
    else:
        np.testing.assert_allclose(engaged, before + 1.0 * np.array([-0.04, 0.01, 0.0]) * 0.01)  # integrating again
