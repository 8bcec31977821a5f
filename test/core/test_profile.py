"""Force profile F_c (paper Eq. 1, docs/CONTROL_LAWS.md): continuity, oddness, Lipschitz bound, saturation, energy."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.errors import FicInputError
from fic_core.profile import ForceProfile, force_profile


@st.composite
def profiles(draw) -> ForceProfile:
    stiffness = draw(st.floats(1.0, 5000.0))
    saturation_error = draw(st.floats(1e-3, 0.5))
    # xi = 0 (no linear region) or a linear region a fine grid can resolve.
    saturation_start = draw(st.one_of(st.just(0.0), st.floats(0.01, 0.99)))
    linear_limit_force = saturation_start * stiffness * saturation_error
    max_force = linear_limit_force + draw(st.floats(0.1, 100.0))
    return ForceProfile(stiffness, saturation_error, saturation_start, max_force)


def paper_printed_profile(error: float, p: ForceProfile) -> float:
    """Eq. 1 as printed, with only the unit erratum fixed (argument (a - x_b)/S + pi): jumps at xi*x_b."""
    a = abs(error)
    if a <= p.linear_limit:
        return p.stiffness * error
    force_span = p.max_force - p.linear_limit_force
    value = force_span / 2.0 * (math.tanh((a - p.saturation_error) / p.saturation_width + math.pi) + 1.0)
    return math.copysign(value + p.linear_limit_force, error)


def test_known_values() -> None:
    p = ForceProfile(stiffness=1000.0, saturation_error=0.05, saturation_start=0.5, max_force=40.0)
    # Linear region: K0*e.
    assert p.force(0.01) == pytest.approx(10.0)
    assert p.force(-0.025) == pytest.approx(-25.0)
    # At a = x_b the tanh argument is pi: F0 + dF*(tanh(pi) - tanh(-pi))/(1 - tanh(-pi)).
    expected = 25.0 + 15.0 * (2 * math.tanh(math.pi)) / (1 + math.tanh(math.pi))
    assert p.force(0.05) == pytest.approx(expected, rel=1e-12)
    # Far away: F_max.
    assert p.force(10.0) == pytest.approx(40.0, rel=1e-12)
    # The module function and the method agree.
    errors = np.linspace(-0.2, 0.2, 101)
    np.testing.assert_array_equal(
        force_profile(errors, stiffness=1000.0, saturation_error=0.05, saturation_start=0.5, max_force=40.0),
        p.force(errors))


def test_renormalisation_removes_the_printed_jump() -> None:
    """The printed profile jumps by dF*(1 + tanh(-pi))/2 at xi*x_b; the renormalised one does not."""
    p = ForceProfile(stiffness=1000.0, saturation_error=0.05, saturation_start=0.5, max_force=40.0)
    below, above = p.linear_limit, p.linear_limit + 1e-12
    printed_jump = paper_printed_profile(above, p) - paper_printed_profile(below, p)
    assert printed_jump == pytest.approx(15.0 * (1 + math.tanh(-math.pi)) / 2, rel=1e-6)
    assert abs(float(p.force(above) - p.force(below))) < 1e-6


@settings(max_examples=200, deadline=None)
@given(profiles(), st.floats(-1.0, 1.0))
def test_odd(p: ForceProfile, error: float) -> None:
    assert float(p.force(-error)) == -float(p.force(error))


@settings(max_examples=200, deadline=None)
@given(profiles())
def test_continuous_at_saturation_start(p: ForceProfile) -> None:
    start = p.linear_limit
    for step in (1e-7, 1e-9):
        left, right = float(p.force(start - step)), float(p.force(start + step))
        # Any jump would show up as a difference not shrinking with the step; the Lipschitz slope bounds it.
        assert abs(right - left) <= 2 * step * p.lipschitz_bound() * (1 + 1e-6) + 1e-9


@settings(max_examples=200, deadline=None)
@given(profiles(), st.floats(-2.0, 2.0), st.floats(-2.0, 2.0))
def test_lipschitz_bound_holds_for_difference_quotients(p: ForceProfile, a: float, b: float) -> None:
    difference = abs(float(p.force(a)) - float(p.force(b)))
    assert difference <= p.lipschitz_bound() * abs(a - b) * (1 + 1e-9) + 1e-9


@settings(max_examples=40, deadline=None)
@given(profiles())
def test_lipschitz_bound_is_tight(p: ForceProfile) -> None:
    """The bound is not vacuous: the steepest finite-difference slope on a fine grid comes within 1 % of it."""
    errors = np.linspace(0.0, 2.0 * p.saturation_error, 400_001)
    slopes = np.diff(p.force(errors)) / np.diff(errors)
    assert slopes.max() <= p.lipschitz_bound() * (1 + 1e-9)
    assert slopes.max() >= 0.99 * p.lipschitz_bound()


@settings(max_examples=200, deadline=None)
@given(profiles(), st.floats(0.0, 100.0))
def test_bounded_by_max_force_and_monotone(p: ForceProfile, error: float) -> None:
    force = float(p.force(error))
    assert 0.0 <= force <= p.max_force * (1 + 1e-12)
    assert float(p.force(error + 1e-3)) >= force - 1e-12


@settings(max_examples=100, deadline=None)
@given(profiles())
def test_saturates_to_max_force(p: ForceProfile) -> None:
    far = p.saturation_error + 40 * p.saturation_width  # tanh(40 + pi) = 1 to double precision
    assert float(p.force(far)) == pytest.approx(p.max_force, rel=1e-12, abs=1e-12)
    assert float(p.force(-far)) == pytest.approx(-p.max_force, rel=1e-12, abs=1e-12)


@settings(max_examples=100, deadline=None)
@given(profiles(), st.floats(0.0, 1.0))
def test_energy_is_the_integral_of_the_force(p: ForceProfile, fraction: float) -> None:
    error = fraction * 2.0 * p.saturation_error
    grid = np.linspace(0.0, error, 20_001)
    numeric = np.trapezoid(p.force(grid), grid) if hasattr(np, "trapezoid") else np.trapz(p.force(grid), grid)
    scale = p.max_force * p.saturation_error
    assert float(p.energy(error)) == pytest.approx(numeric, rel=1e-6, abs=1e-9 * scale)
    assert float(p.energy(-error)) == float(p.energy(error))


@settings(max_examples=100, deadline=None)
@given(profiles(), st.floats(-1.0, 1.0))
def test_secant_stiffness(p: ForceProfile, error: float) -> None:
    secant = float(p.secant_stiffness(error))
    if abs(error) > 1e-6:
        assert secant == pytest.approx(float(p.force(error)) / error, rel=1e-9)
    assert 0.0 <= secant <= p.lipschitz_bound() * (1 + 1e-9)
    # The limit at zero: K0 with a linear region, else the tanh's tangent slope.
    near_zero = p.linear_limit / 2 if p.linear_limit > 0 else 1e-7 * p.saturation_error
    assert float(p.secant_stiffness(0.0)) == pytest.approx(float(p.force(near_zero)) / near_zero, rel=1e-3)


def test_saturation_start_one_is_rejected() -> None:
    with pytest.raises(FicInputError, match="saturation_start"):
        ForceProfile(stiffness=1000.0, saturation_error=0.05, saturation_start=1.0, max_force=60.0)
    with pytest.raises(FicInputError, match="saturation_start"):
        force_profile(0.1, stiffness=1000.0, saturation_error=0.05, saturation_start=1.0, max_force=60.0)


@pytest.mark.parametrize("field, value", [
    ("stiffness", 0.0), ("stiffness", -1.0), ("stiffness", math.nan), ("stiffness", math.inf),
    ("saturation_error", 0.0), ("saturation_error", math.nan),
    ("saturation_start", -0.1), ("saturation_start", math.nan),
    ("max_force", 10.0),  # below F0 = 0.5*1000*0.05 = 25 N
    ("max_force", math.inf),
])
def test_invalid_parameters_name_the_parameter(field: str, value: float) -> None:
    parameters = dict(stiffness=1000.0, saturation_error=0.05, saturation_start=0.5, max_force=40.0)
    parameters[field] = value
    with pytest.raises(FicInputError, match=field):
        ForceProfile(**parameters)
    error = 0.01
    with pytest.raises(FicInputError, match=field):
        force_profile(error, **parameters)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_errors_are_rejected(bad: float) -> None:
    p = ForceProfile(stiffness=1000.0, saturation_error=0.05, saturation_start=0.5, max_force=40.0)
    for call in (p.force, p.energy, p.secant_stiffness):
        with pytest.raises(FicInputError, match="error"):
            call(np.array([0.0, bad]))
    with pytest.raises(FicInputError, match="error"):
        force_profile([bad], stiffness=1000.0, saturation_error=0.05, saturation_start=0.5, max_force=40.0)


def test_the_secant_stiffness_at_the_end_of_the_linear_region_is_k0_exactly() -> None:
    """xi x_b is the largest |e| of the linear region (F_c = K0 e there, Eq. 1's first line): its secant stiffness
    is K0 itself, in the array and the float form, on either side, not K0 xi x_b / (xi x_b) rounded (which misses
    K0 by an ulp for about one profile in ten of these)."""
    rng = np.random.default_rng(146)
    for _ in range(200):
        profile = ForceProfile(rng.uniform(1.0, 5000.0), rng.uniform(1e-3, 1.0), rng.uniform(0.01, 0.99), 1e6)
        for error in (profile.linear_limit, -profile.linear_limit):
            assert float(profile.force(error)) == profile.stiffness * error
            assert float(profile.secant_stiffness(error)) == profile.stiffness, profile
            assert profile.scalar_secant_stiffness(error) == profile.stiffness, profile


@pytest.mark.parametrize("stiffness, saturation_start, max_force", [(1e4, 1e-11, 30.0), (1e4, 1e-11, 1e-5),
                                                                    (200.0, 1e-12, 30.0), (5e3, 0.0, 2.0)])
def test_just_past_a_tiny_linear_region_the_secant_follows_the_tangent_at_its_end(
        stiffness: float, saturation_start: float, max_force: float) -> None:
    """Below 1e-9 x_b (and past xi x_b) F_c(a)/a is taken from the line F0 + F_c'(xi x_b+) (a - xi x_b), as the
    difference of two tanh values loses its digits there: the slope is Eq. 1's derivative at the start of the
    saturation, dF / (1 - tanh(-pi)) x sech^2(-pi) / S, recomputed here from the parameters."""
    saturation_error = 0.05
    profile = ForceProfile(stiffness, saturation_error, saturation_start, max_force)
    start = saturation_start * saturation_error
    start_force = saturation_start * stiffness * saturation_error
    width = (1.0 - saturation_start) * saturation_error / (2.0 * math.pi)
    slope = (max_force - start_force) / (1.0 - math.tanh(-math.pi)) * (1.0 - math.tanh(-math.pi) ** 2) / width
    for magnitude in (start * 2.0 + 1e-14, 4e-12, 1e-11, 4e-11):
        assert start < magnitude <= 1e-9 * saturation_error
        expected = (start_force + slope * (magnitude - start)) / magnitude
        for value in (float(profile.secant_stiffness(magnitude)), profile.scalar_secant_stiffness(magnitude)):
            assert math.isclose(value, expected, rel_tol=1e-13), (magnitude, value, expected)
    if saturation_start == 0.0:   # no linear region: the secant at 0 is that slope
        assert math.isclose(float(profile.secant_stiffness(0.0)), slope, rel_tol=1e-13)
        assert math.isclose(profile.scalar_secant_stiffness(0.0), slope, rel_tol=1e-13)


@settings(max_examples=120, deadline=None, derandomize=True)
@given(profiles(), st.floats(0.0, 1.0), st.sampled_from([1e-6, 0.01, 0.5, 1.0, 2.0, 30.0, 1e4]))
def test_the_inverse_storage_is_v_d_inverted_from_the_linear_region_to_far_saturation(
        p: ForceProfile, fraction: float, scale: float) -> None:
    """energy_inverse(E) is the a >= 0 with V_D(a) = E (rounded to the smaller storage), for storages inside the
    linear region (K0 a^2 / 2), just past it, and far into the saturation (where V_D grows like F_max a), with
    xi = 0 (no linear region) too: V_D at the result is at most E (up to V_D's own rounding, a few ulps of F_max
    x_b), and, for a storage well above that rounding, a result a relative 1e-9 larger stores more than E."""
    linear_energy = 0.5 * p.stiffness * p.linear_limit ** 2
    energy = fraction * scale * (linear_energy if linear_energy > 0.0 else float(p.energy(p.saturation_error)))
    magnitude = p.energy_inverse(energy)
    assert magnitude >= 0.0
    assert float(p.energy(magnitude)) <= energy + 1e-12 * (energy + p.max_force * p.saturation_error)
    if energy > 1e-6 * p.max_force * p.saturation_error:
        assert float(p.energy(magnitude * (1.0 + 1e-9))) > energy
    if 0.0 < energy <= linear_energy:
        assert magnitude == pytest.approx(math.sqrt(2.0 * energy / p.stiffness), rel=1e-11)


def test_the_inverse_storage_of_nothing_is_zero_and_a_negative_storage_is_refused() -> None:
    p = ForceProfile(200.0, 0.05, 0.0, 30.0)   # xi = 0: the saturation from the origin
    assert p.energy_inverse(0.0) == 0.0
    with pytest.raises(FicInputError, match="energy"):
        p.energy_inverse(-1e-9)
    far = 1000.0 * float(p.energy(p.saturation_error))   # found by doubling from x_b, then Newton
    assert float(p.energy(p.energy_inverse(far))) == pytest.approx(far, rel=1e-9)
