"""The angle-axis FIC on orientation (fic_core/rotational_attractor.py): the moment is the gradient of its storage on
SO(3), and closed orientation loops driven from outside take no net energy out of it, where the per-axis rule on
the rotation vector (the replica's law before) gives energy out (docs/CONTROL_LAWS.md, "Rotation")."""
from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from fic_core.attractor import FractalAttractor
from fic_core.errors import FicInputError
from fic_core.passivity_observer import PassivityObserver
from fic_core.profile import ForceProfile
from fic_core.rotational_attractor import RotationalAttractor
from fic_teleop_experiments.tools.orientation_loops import drive_loop, loop_rotation_vectors
from fic_teleop_experiments.tools.passivity_oracle import shipped_profiles

#: The replica's shipped rotation profile (config/replica.yaml): 20 N m/rad, x_b = 0.5 rad, xi = 0.5, a flat clamp
#: at F_max = F0 = 5 N m from 0.25 rad.
SHIPPED_ROTATION = next(profile for name, profile in shipped_profiles().items() if "replica.yaml:rotation_" in name)
#: A profile whose tanh stiffens before it saturates (F_max = 2 K0 x_b): the C phase then matters more.
STIFFENING = ForceProfile(20.0, 0.5, 0.5, 20.0)
#: A rate dead-band no loop here reaches: the attractor stays in D, so the loop probes the field alone.
NO_SWITCHING = 1e3


def old_per_axis_rule(profile: ForceProfile, rate_deadband: float):
    """The replica's rotation law before the angle-axis FIC, kept as the negative control: Eq. 2 per component of
    r = log3(R_d R^T) (a 3-axis FractalAttractor), the result applied as a base-frame moment."""
    attractor = FractalAttractor(profile, 3, rate_deadband)
    return lambda rotation_error, rate: attractor.force(rotation_error, rate)


def angle_axis_rule(profile: ForceProfile, rate_deadband: float):
    attractor = RotationalAttractor(profile, rate_deadband)
    return attractor, (lambda rotation_error, rate: attractor.moment(rotation_error, rate))


@pytest.mark.parametrize("profile", [SHIPPED_ROTATION, STIFFENING], ids=["shipped", "stiffening"])
def test_the_moment_is_minus_the_gradient_of_the_storage_on_so3(profile: ForceProfile) -> None:
    """V(R) = V_D(|log3(R_d R^T)|); turning the robot by w h (base frame, R -> exp(w h) R) changes V by -M . w h
    to first order: the central difference converges to it with an error O(h^2), for angles from 0.05 to 3 rad and
    with the target turning too (then d theta/dt = u . (w_d - w))."""
    rng = np.random.default_rng(3)
    for angle in (0.05, 0.3, 0.7, 1.2, 2.0, 3.0):
        for _ in range(4):
            axis = rng.normal(size=3)
            axis /= np.linalg.norm(axis)
            desired = pin.exp3(rng.normal(size=3))
            robot = pin.exp3(-angle * axis) @ desired  # R_d R^T = exp(angle axis)
            error = pin.log3(desired @ robot.T)
            assert np.linalg.norm(error) == pytest.approx(angle, abs=1e-12)
            attractor = RotationalAttractor(profile, NO_SWITCHING)
            moment = attractor.moment(error, np.zeros(3))
            omega, omega_desired = rng.normal(size=3), rng.normal(size=3)

            def storage(step: float) -> float:
                turned = pin.exp3(omega * step) @ robot  # noqa: B023
                target = pin.exp3(omega_desired * step) @ desired  # noqa: B023
                return float(profile.energy(np.linalg.norm(pin.log3(target @ turned.T))))

            # The power into the controller: F(theta) d theta/dt = M . (w_d - w) (moment along the axis).
            power = float(moment @ (omega_desired - omega))
            errors = [abs((storage(step) - storage(-step)) / (2 * step) - power) for step in (1e-3, 1e-4)]
            # The central difference's error is O(h^2): a hundredfold smaller at a tenfold smaller step.
            assert errors[1] <= max(1e-8, 0.05 * errors[0]), (angle, errors, power)
            assert errors[1] <= 1e-5 * max(1.0, abs(power)), (angle, errors, power)


def test_the_moment_is_the_profile_along_the_axis_and_the_linear_region_is_unchanged() -> None:
    """|M| = F_c(theta) along r/theta; below xi x_b it is K0 r, exactly the old per-axis law there."""
    attractor = RotationalAttractor(SHIPPED_ROTATION, NO_SWITCHING)
    old = old_per_axis_rule(SHIPPED_ROTATION, NO_SWITCHING)
    small = np.array([0.1, -0.12, 0.05])  # |r| = 0.164 < 0.25 rad
    np.testing.assert_allclose(attractor.moment(small, np.ones(3)), old(small, np.ones(3)), rtol=1e-12)
    np.testing.assert_allclose(attractor.moment(small, np.ones(3)), SHIPPED_ROTATION.stiffness * small, rtol=1e-12)
    large = np.array([0.9, -0.4, 0.3])
    moment = attractor.moment(large, np.ones(3))
    angle = float(np.linalg.norm(large))
    np.testing.assert_allclose(moment, float(SHIPPED_ROTATION.force(angle)) * large / angle, rtol=1e-12)
    assert np.linalg.norm(moment) <= SHIPPED_ROTATION.max_force * (1 + 1e-12)
    assert attractor.moment(np.zeros(3), np.ones(3)).tolist() == [0.0, 0.0, 0.0]
    assert attractor.stored_energy[0] == 0.0


@pytest.mark.parametrize("dt", [1e-3, 2e-3, 1e-2], ids=["1kHz", "500Hz", "100Hz"])
@pytest.mark.parametrize("amplitude", [0.2, 0.5, 0.8, 1.2])
def test_closed_orientation_loops_give_no_net_energy_out(amplitude: float, dt: float) -> None:
    """Driven round a closed loop from rest to rest at 0.3 and 1.5 rad/s, with and without phase switching, on the
    shipped and a stiffening profile: the held-moment work done on the controller is >= -(sampling tolerance)
    (orientation_loops: the held moment's lag plus the finite-step angle term, both O(dt), computed from the run),
    and the angle's port, booked by the per-axis passivity observer, never has a margin below -1e-12 J."""
    for profile in (SHIPPED_ROTATION, STIFFENING):
        for speed in (0.3, 1.5):
            for deadband in (NO_SWITCHING, 0.005):
                attractor, law = angle_axis_rule(profile, deadband)
                observer = PassivityObserver(3, tolerance=1e-12)

                def observed(rotation_error, rate, attractor=attractor, law=law, observer=observer):
                    moment = law(rotation_error, rate)
                    observer.observe_snapshot(attractor.snapshot())
                    return moment

                run = drive_loop(observed, loop_rotation_vectors(amplitude, speed, dt), dt)
                assert run.zoh_work >= -run.sampling_tolerance - 1e-12, (profile, speed, deadband, run.zoh_work)
                assert observer.min_margin >= -1e-12 and observer.violation_ticks == 0
                if deadband == NO_SWITCHING:
                    # A priori, without switches: both sampling terms are at most L sum |phi_k|^2 each (L the
                    # profile's Lipschitz bound, which also bounds F(theta)/theta), i.e. 2 L |w| dt per radian.
                    assert run.sampling_tolerance <= 2.0 * profile.lipschitz_bound() * np.sum(run.increments ** 2)
                assert attractor.stored_energy[0] == 0.0  # back at rest


@pytest.mark.parametrize("amplitude", [0.5, 0.8, 1.2])
def test_the_old_per_axis_rule_gives_energy_out_on_the_same_loops(amplitude: float) -> None:
    """The negative control: the per-axis rule on r, driven below the rate dead-band (no switching), fails the same
    test on the same samples at 1 kHz, 500 Hz and 100 Hz: its held-moment work is below minus twice the a priori
    sampling tolerance 2 L sum |phi_k|^2 (the data-derived terms cannot judge it: its moment is not along r, so
    its 'geometric term' is first order), while the angle-axis law stays above minus that tolerance."""
    for dt, speed in ((1e-3, 0.1), (2e-3, 0.1), (1e-2, 0.02)):
        vectors = loop_rotation_vectors(amplitude, speed, dt)
        old = drive_loop(old_per_axis_rule(SHIPPED_ROTATION, NO_SWITCHING), vectors, dt)
        new = drive_loop(angle_axis_rule(SHIPPED_ROTATION, NO_SWITCHING)[1], vectors, dt)
        tolerance = 2.0 * SHIPPED_ROTATION.lipschitz_bound() * float(np.sum(new.increments ** 2))
        assert old.zoh_work < -2.0 * tolerance, (amplitude, dt, old.zoh_work, tolerance)
        assert new.zoh_work >= -tolerance


def test_the_sampling_tolerance_vanishes_linearly_with_the_period() -> None:
    """The held-moment shortfall of the angle-axis law on a loop halves when dt halves (a sampling term, not a
    leak of the field): 0.8 rad loop at 1 rad/s, no switching, dt = 4, 2, 1 ms."""
    shortfalls = []
    for dt in (4e-3, 2e-3, 1e-3):
        run = drive_loop(angle_axis_rule(SHIPPED_ROTATION, NO_SWITCHING)[1], loop_rotation_vectors(0.8, 1.0, dt), dt)
        shortfalls.append(-run.zoh_work)
        assert 0.0 < -run.zoh_work <= run.sampling_tolerance
    ratios = [coarse / fine for coarse, fine in zip(shortfalls[:-1], shortfalls[1:])]
    assert all(1.7 <= ratio <= 2.3 for ratio in ratios), (shortfalls, ratios)


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_bad_input_is_refused_in_one_line(bad: float) -> None:
    attractor = RotationalAttractor(SHIPPED_ROTATION)
    with pytest.raises(FicInputError, match="rotation_error"):
        attractor.moment([0.0, bad, 0.0], np.zeros(3))
    with pytest.raises(FicInputError, match="rotation_error_rate"):
        attractor.moment(np.zeros(3), [bad, 0.0, 0.0])
    with pytest.raises(FicInputError, match="profile"):
        RotationalAttractor("not a profile")  # type: ignore[arg-type]
