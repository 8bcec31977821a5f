"""Master law (paper Eq. 3): f = FIC(-x_M) + k_F*K_H*F_R, haptic gain clamped to [0, 1], device force saturation,
the loop-gain bound k_F*s_M*K_H <= 1."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_core.attractor import FractalAttractor
from fic_core.errors import FicInputError
from fic_core.master import MAX_LOOP_GAIN, MasterLaw, checked_loop_gain, haptic_gain_ceiling
from fic_core.profile import ForceProfile

PROFILE = ForceProfile(stiffness=200.0, saturation_error=0.03, saturation_start=0.5, max_force=8.0)


def make_master(haptic_gain: float = 0.5, max_device_force: float | None = None) -> MasterLaw:
    return MasterLaw(FractalAttractor(PROFILE, 3, rate_deadband=0.005), haptic_gain, max_device_force)


def test_restoring_force_opposes_the_handle_displacement() -> None:
    master = make_master(haptic_gain=0.0)
    force = master.force([0.01, -0.02, 0.0], [0.0, 0.0, 0.0], [5.0, 5.0, 5.0])
    np.testing.assert_allclose(force, -PROFILE.force([0.01, -0.02, 0.0]))
    assert force[0] < 0 < force[1]


def test_replica_force_is_scaled_by_the_haptic_gain() -> None:
    replica_force = np.array([10.0, -4.0, 2.0])
    for gain in (0.0, 0.3, 1.0):
        master = make_master(haptic_gain=gain)
        np.testing.assert_allclose(master.force(np.zeros(3), np.zeros(3), replica_force), gain * replica_force)


def test_replica_force_is_scaled_by_the_force_scale_too() -> None:
    replica_force = np.array([1.0, -4.0, 2.0])
    master = MasterLaw(FractalAttractor(PROFILE, 3, rate_deadband=0.005), 0.5, None, force_scale=3.0)
    np.testing.assert_allclose(master.force(np.zeros(3), np.zeros(3), replica_force), 1.5 * replica_force)
    master.force_scale = 0.0
    np.testing.assert_allclose(master.force(np.zeros(3), np.zeros(3), replica_force), 0.0)
    with pytest.raises(FicInputError, match="force_scale"):
        master.force_scale = -1.0


def test_the_loop_gain_bound() -> None:
    """k_F s_M K_H <= 1: a finer motion scale buys a larger force scale; past the bound, one line naming the three
    figures and the product."""
    assert MAX_LOOP_GAIN == 1.0
    assert checked_loop_gain(4.0, 0.25, 1.0) == 1.0 and checked_loop_gain(1.0, 1.0, 0.5) == 0.5
    with pytest.raises(FicInputError) as refusal:
        checked_loop_gain(2.0, 1.0, 0.6)
    message = str(refusal.value)
    assert "force_scale x workspace_scale x haptic_gain = 2 x 1 x 0.6 = 1.2" in message and "\n" not in message
    assert haptic_gain_ceiling(2.0, 1.0) == 0.5 and haptic_gain_ceiling(0.5, 1.0) == 1.0
    assert haptic_gain_ceiling(0.0, 1.0) == 1.0


def test_haptic_gain_is_clamped_and_the_clamp_reported() -> None:
    master = make_master()
    assert master.set_haptic_gain(0.7) is False and master.haptic_gain == 0.7
    assert master.set_haptic_gain(5.0) is True and master.haptic_gain == 1.0
    assert master.haptic_gain_clamped
    assert master.set_haptic_gain(-0.2) is True and master.haptic_gain == 0.0
    master.haptic_gain = 1.5
    assert master.haptic_gain == 1.0 and master.haptic_gain_clamped
    master.haptic_gain = 0.25
    assert master.haptic_gain == 0.25 and not master.haptic_gain_clamped
    assert make_master(haptic_gain=3.0).haptic_gain == 1.0
    # Clamped gain really is what scales F_R.
    master.set_haptic_gain(4.0)
    assert master.force(np.zeros(3), np.zeros(3), [10.0, 0.0, 0.0])[0] == pytest.approx(10.0)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_haptic_gain_is_rejected_and_the_old_value_kept(bad: float) -> None:
    master = make_master(haptic_gain=0.4)
    with pytest.raises(FicInputError, match="haptic_gain"):
        master.set_haptic_gain(bad)
    assert master.haptic_gain == 0.4


def test_device_force_saturation_keeps_the_direction() -> None:
    master = make_master(haptic_gain=1.0, max_device_force=20.0)
    force = master.force(np.zeros(3), np.zeros(3), [30.0, 40.0, 0.0])
    assert np.linalg.norm(force) == pytest.approx(20.0)
    np.testing.assert_allclose(force / np.linalg.norm(force), [0.6, 0.8, 0.0])
    assert master.device_force_saturated
    master.force(np.zeros(3), np.zeros(3), [3.0, 4.0, 0.0])
    assert not master.device_force_saturated


def test_handle_released_returns_to_the_origin() -> None:
    """A device-like 0.2 kg handle released at 2 cm under the master law settles at the origin."""
    master = make_master(haptic_gain=0.0)
    mass, x, v, dt = 0.2, np.array([0.02, -0.01, 0.0]), np.zeros(3), 2e-4
    for _ in range(5000):
        force = master.force(x, v, np.zeros(3))
        v = v + force / mass * dt
        x = x + v * dt
    assert np.linalg.norm(x) < 2e-4


def test_invalid_inputs_are_rejected() -> None:
    master = make_master()
    for name, arguments in [("handle_position", ([math.nan, 0, 0], [0, 0, 0], [0, 0, 0])),
                            ("handle_velocity", ([0, 0, 0], [0, math.inf, 0], [0, 0, 0])),
                            ("replica_force", ([0, 0, 0], [0, 0, 0], [0, 0, math.nan]))]:
        with pytest.raises(FicInputError, match=name):
            master.force(*arguments)
    with pytest.raises(FicInputError, match="max_device_force"):
        make_master(max_device_force=math.nan)
    with pytest.raises(FicInputError, match="max_device_force"):
        make_master(max_device_force=0.0)
    with pytest.raises(FicInputError, match="attractor"):
        MasterLaw(FractalAttractor(PROFILE, 6), 0.5)


def test_reset_clears_the_device_saturation_flag() -> None:
    """After ``reset`` (the handle homed) no force has been commanded yet, so none was saturated."""
    master = make_master(haptic_gain=1.0, max_device_force=20.0)
    master.force(np.zeros(3), np.zeros(3), [30.0, 40.0, 0.0])
    assert master.device_force_saturated
    master.reset()
    assert not master.device_force_saturated


def test_a_guidance_force_is_added_before_the_devices_bound_and_the_bound_is_set_live() -> None:
    """f = FIC(-x_M) + k_F K_H F_R + the fixture's force, then scaled as a vector to the device's bound: the
    fixture's force counts toward the bound (a sum over it is scaled, direction kept), and the bound set while
    running (None: unbounded; not positive or not finite: refused by name, the old bound kept) applies at once."""
    master = make_master(haptic_gain=0.5, max_device_force=20.0)
    guidance = np.array([0.0, 0.0, -4.0])
    force = master.force(np.zeros(3), np.zeros(3), [6.0, 0.0, 0.0], guidance)
    np.testing.assert_allclose(force, [3.0, 0.0, -4.0])
    assert not master.device_force_saturated
    force = master.force(np.zeros(3), np.zeros(3), [24.0, 0.0, 0.0], np.array([0.0, 0.0, -16.0]))
    np.testing.assert_allclose(force, [12.0, 0.0, -16.0])   # 20 N exactly: on the bound, not past it
    force = master.force(np.zeros(3), np.zeros(3), [48.0, 0.0, 0.0], np.array([0.0, 0.0, -32.0]))
    np.testing.assert_allclose(force, [12.0, 0.0, -16.0])
    assert master.device_force_saturated
    master.max_device_force = 10.0
    assert master.max_device_force == 10.0
    np.testing.assert_allclose(master.force(np.zeros(3), np.zeros(3), [48.0, 0.0, 0.0], np.array([0.0, 0.0, -32.0])),
                               [6.0, 0.0, -8.0])
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(FicInputError, match="max_device_force"):
            master.max_device_force = bad
        assert master.max_device_force == 10.0
    master.max_device_force = None
    np.testing.assert_allclose(master.force(np.zeros(3), np.zeros(3), [48.0, 0.0, 0.0], np.array([0.0, 0.0, -32.0])),
                               [24.0, 0.0, -32.0])
    assert not master.device_force_saturated


def test_the_loop_gain_bound_is_exact_at_one() -> None:
    """G = 1 is allowed however the product is rounded (k_F s_M K_H = 3 x (1/3) x 1), a part in a million above
    it is refused; the K_H ceiling is 1 up to scales whose product is 1 and their inverse above it."""
    assert checked_loop_gain(3.0, 1.0 / 3.0, 1.0) == pytest.approx(1.0, rel=1e-15)
    assert checked_loop_gain(10.0, 0.1, 1.0) == pytest.approx(1.0, rel=1e-15)
    with pytest.raises(FicInputError, match="loop-gain bound"):
        checked_loop_gain(1.0, 1.0, 1.000001)
    assert haptic_gain_ceiling(4.0, 0.25) == 1.0
    assert haptic_gain_ceiling(4.0, 0.5) == 0.5 and haptic_gain_ceiling(1.0, 1.25) == pytest.approx(0.8)


def test_reset_puts_the_handles_fic_back_in_divergence_at_rest() -> None:
    """After a swing in C (the handle moving back toward the origin), reset: D on every axis, nothing latched, and
    the next force is the profile's F_c again."""
    master = make_master(haptic_gain=0.0)
    master.force([0.02, 0.0, 0.0], [0.0, 0.0, 0.0], np.zeros(3))
    master.force([0.019, 0.0, 0.0], [-0.5, 0.0, 0.0], np.zeros(3))   # returning: error magnitude falling
    assert master.attractor.phase[0] == 1
    master.reset()
    np.testing.assert_array_equal(master.attractor.phase, [0, 0, 0])
    np.testing.assert_array_equal(master.attractor.latched_max_error, [0.0, 0.0, 0.0])
    np.testing.assert_allclose(master.force([0.019, 0.0, 0.0], [-0.5, 0.0, 0.0], np.zeros(3)),
                               -PROFILE.force([0.019, 0.0, 0.0]))
