"""Linear impedance baseline: same interface as PoseAttractor, K0 from the FIC, damping from a damping ratio."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.baseline import LinearImpedance, make_baseline_like
from fic_core.errors import FicInputError
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile

TRANSLATION = ForceProfile(stiffness=1000.0, saturation_error=0.05, saturation_start=0.5, max_force=40.0)
ROTATION = ForceProfile(stiffness=40.0, saturation_error=0.5, saturation_start=0.5, max_force=15.0)


def test_spring_damper_wrench_and_energy() -> None:
    baseline = LinearImpedance(1000.0, 40.0, 90.0, 4.0)
    assert baseline.controller_name == "linear"
    wrench = baseline.wrench([0.01, -0.02, 0.0], [0.1, 0.0, -0.2], [0.5, 0.0, 0.0, 0.0, 1.0, 0.0])
    np.testing.assert_allclose(wrench, [10.0 + 45.0, -20.0, 0.0, 4.0, 4.0, -8.0])
    np.testing.assert_allclose(baseline.last_force, wrench)
    np.testing.assert_allclose(baseline.stored_energy, [0.05, 0.2, 0.0, 0.2, 0.0, 0.8])
    assert np.all(baseline.phase == 0) and np.all(baseline.latched_max_error == 0)
    baseline.reset()
    assert np.all(baseline.stored_energy == 0) and np.all(baseline.last_force == 0)


def test_no_saturation_unlike_the_fic() -> None:
    baseline = make_baseline_like(PoseAttractor(TRANSLATION, ROTATION))
    fic = PoseAttractor(TRANSLATION, ROTATION)
    error, zero = np.array([0.5, 0.0, 0.0]), np.zeros(3)
    assert baseline.wrench(error, zero, np.zeros(6))[0] == pytest.approx(500.0)
    assert fic.wrench(error, zero, np.zeros(6))[0] <= TRANSLATION.max_force


def test_make_baseline_like_uses_k0_and_the_damping_ratio() -> None:
    baseline = make_baseline_like(PoseAttractor(TRANSLATION, ROTATION), damping_ratio=0.7, effective_mass=4.0,
                                  effective_inertia=0.1)
    np.testing.assert_allclose(baseline.stiffness, [1000.0] * 3 + [40.0] * 3)
    np.testing.assert_allclose(baseline.damping[:3], 2 * 0.7 * math.sqrt(1000.0 * 4.0))
    np.testing.assert_allclose(baseline.damping[3:], 2 * 0.7 * math.sqrt(40.0 * 0.1))


def test_damped_mass_decays_with_the_chosen_damping_ratio() -> None:
    """A 4 kg mass under the baseline is an under-damped oscillator with zeta = 0.7: overshoot
    exp(-pi*z/sqrt(1-z^2))."""
    baseline = make_baseline_like(PoseAttractor(TRANSLATION, ROTATION), damping_ratio=0.7, effective_mass=4.0)
    mass, x, v, dt = 4.0, -0.01, 0.0, 1e-5
    peak = 0.0
    for _ in range(40_000):
        force = baseline.wrench([-x, 0.0, 0.0], np.zeros(3), [-v, 0, 0, 0, 0, 0])[0]
        v += force / mass * dt
        x += v * dt
        peak = max(peak, x)
    expected_overshoot = 0.01 * math.exp(-math.pi * 0.7 / math.sqrt(1 - 0.7 ** 2))
    assert peak == pytest.approx(expected_overshoot, rel=0.02)


@pytest.mark.parametrize("name", ["translation_stiffness", "rotation_stiffness", "translation_damping",
                                  "rotation_damping"])
@pytest.mark.parametrize("bad", [math.nan, math.inf, -1.0])
def test_invalid_parameters_are_rejected(name: str, bad: float) -> None:
    parameters = dict(translation_stiffness=1000.0, rotation_stiffness=40.0, translation_damping=90.0,
                      rotation_damping=4.0)
    parameters[name] = bad
    with pytest.raises(FicInputError, match=name):
        LinearImpedance(**parameters)


def test_non_finite_signals_are_rejected() -> None:
    baseline = LinearImpedance(1000.0, 40.0, 90.0, 4.0)
    with pytest.raises(FicInputError, match="position_error"):
        baseline.wrench([math.nan, 0, 0], [0, 0, 0], np.zeros(6))
    with pytest.raises(FicInputError, match="rotation_error"):
        baseline.wrench([0, 0, 0], [0, math.inf, 0], np.zeros(6))
    with pytest.raises(FicInputError, match="twist_error"):
        baseline.wrench([0, 0, 0], [0, 0, 0], [0, 0, 0, 0, 0, math.nan])
    with pytest.raises(FicInputError, match="damping_ratio"):
        make_baseline_like(PoseAttractor(TRANSLATION, ROTATION), damping_ratio=math.nan)


def test_bounded_baseline_stops_at_f_max_and_equals_the_spring_below_it():
    """The like-for-like baseline: K e + D de/dt, its force vector scaled back onto |F| = F_max (10 N here)."""
    from fic_core.baseline import LinearImpedance
    free = LinearImpedance(200.0, 20.0, 39.6, 1.98)
    bounded = LinearImpedance(200.0, 20.0, 39.6, 1.98, max_force=(10.0, 5.0))
    small = ([0.01, -0.02, 0.0], [0.0, 0.05, 0.0], [0.01, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert np.allclose(bounded.wrench(*small), free.wrench(*small))
    large = ([0.3, -0.4, 0.0], [1.0, 0.0, 0.0], [0.0] * 6)
    wrench = bounded.wrench(*large)
    assert np.linalg.norm(wrench[:3]) == pytest.approx(10.0)
    assert np.allclose(wrench[:3] / 10.0, [0.6, -0.8, 0.0])       # same direction as K e (60, -80, 0) N
    assert np.linalg.norm(wrench[3:]) == pytest.approx(5.0)
    assert np.linalg.norm(free.wrench(*large)[:3]) == pytest.approx(100.0)


@settings(max_examples=80, deadline=None, derandomize=True)
@given(st.lists(st.floats(-2.0, 2.0), min_size=12, max_size=12))
def test_the_bounded_baseline_is_the_spring_damper_scaled_onto_each_blocks_bound(values) -> None:
    """Whatever the errors and rates: each block's force is the free spring-damper's when that is within its bound
    (10 N, 5 N m), else the same direction scaled onto the bound; the two blocks are bounded apart."""
    free = LinearImpedance(200.0, 20.0, 39.6, 1.98)
    bounded = LinearImpedance(200.0, 20.0, 39.6, 1.98, max_force=(10.0, 5.0))
    assert (free.controller_name, bounded.controller_name) == ("linear", "linear_bounded")
    arguments = (values[:3], values[3:6], values[6:])
    unbounded, wrench = free.wrench(*arguments), bounded.wrench(*arguments)
    for block, bound in ((slice(0, 3), 10.0), (slice(3, 6), 5.0)):
        norm = np.linalg.norm(unbounded[block])
        expected = unbounded[block] if norm <= bound else unbounded[block] * (bound / norm)
        np.testing.assert_allclose(wrench[block], expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(bounded.last_force, wrench)


def test_a_snapshot_is_the_state_of_its_own_call() -> None:
    """port_values gives (errors, forces, K e^2 / 2) of the call it was taken after; later calls do not change it."""
    baseline = LinearImpedance(100.0, 10.0, 0.0, 0.0)
    baseline.wrench([0.1, 0.0, 0.0], [0.0, 0.0, 0.2], np.zeros(6))
    snapshot = baseline.snapshot()
    baseline.wrench([0.3, 0.3, 0.3], [0.3, 0.3, 0.3], np.ones(6))
    errors, forces, storages = snapshot.port_values()
    assert errors == (0.1, 0.0, 0.0, 0.0, 0.0, 0.2) and forces == pytest.approx((10.0, 0.0, 0.0, 0.0, 0.0, 2.0))
    assert storages == pytest.approx([0.5, 0.0, 0.0, 0.0, 0.0, 0.2])
    np.testing.assert_allclose(snapshot.stored_energy, storages)
    np.testing.assert_array_equal(snapshot.phase, 0)
    np.testing.assert_array_equal(snapshot.latched_max_error, 0)


@pytest.mark.parametrize("max_force, words", [((0.0, 5.0), r"max_force\[0\]"), ((10.0, -1.0), r"max_force\[1\]"),
                                              ((math.inf, 5.0), r"max_force\[0\]")])
def test_each_force_bound_must_be_positive_and_finite(max_force, words) -> None:
    with pytest.raises(FicInputError, match=words):
        LinearImpedance(200.0, 20.0, 39.6, 1.98, max_force=max_force)


def test_the_damping_follows_the_effective_mass_and_inertia_and_zero_ratio_is_no_damping() -> None:
    attractor = PoseAttractor(TRANSLATION, ROTATION)
    heavy = make_baseline_like(attractor, damping_ratio=1.0, effective_mass=9.0, effective_inertia=0.4)
    np.testing.assert_allclose(heavy.damping, [2 * math.sqrt(9000.0)] * 3 + [2 * math.sqrt(16.0)] * 3)
    np.testing.assert_array_equal(make_baseline_like(attractor, damping_ratio=0.0).damping, 0.0)
    for name in ("effective_mass", "effective_inertia"):
        with pytest.raises(FicInputError, match=name):
            make_baseline_like(attractor, **{name: 0.0})


def test_a_zero_gain_leaves_its_axes_free() -> None:
    """Each gain may be zero (>= 0, not > 0): a baseline with no rotational spring or damper holds position only,
    one with no translational spring is a pure damper there, and one with no translational damper a spring."""
    position_only = LinearImpedance(1000.0, 0.0, 90.0, 0.0)
    np.testing.assert_allclose(position_only.wrench([0.01, 0.0, 0.0], [0.3, -0.2, 0.1], np.ones(6)),
                               [10.0 + 90.0, 90.0, 90.0, 0.0, 0.0, 0.0])
    damper = LinearImpedance(0.0, 40.0, 90.0, 4.0)
    np.testing.assert_allclose(damper.wrench([0.5, 0.5, 0.5], [0.0, 0.0, 0.0], [0.1, 0.0, 0.0, 0.0, 0.0, 0.0]),
                               [9.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    spring = LinearImpedance(1000.0, 40.0, 0.0, 4.0)
    np.testing.assert_allclose(spring.wrench([0.01, 0.0, 0.0], [0.0, 0.0, 0.0], [5.0, 5.0, 5.0, 0.0, 0.0, 0.0]),
                               [10.0, 0.0, 0.0, 0.0, 0.0, 0.0])
