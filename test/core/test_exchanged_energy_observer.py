"""The exchanged-energy observer (fic_core/exchanged_energy_observer.py) with the observer-side FIC storage
(fic_core/attractor_storage.py): it flags a non-conservative rotation and a non-passive switching rule, and passes
the translational and the angle-axis rotational FIC within the sampling term."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_core.attractor import FractalAttractor
from fic_core.attractor_storage import AttractorStorage, ProfilePotential
from fic_core.errors import FicInputError
from fic_core.exchanged_energy_observer import ExchangedEnergyObserver
from fic_core.profile import ForceProfile
from fic_core.rotational_attractor import RotationalAttractor
from fic_teleop_experiments.tools.orientation_loops import drive_loop, loop_rotation_vectors
from fic_teleop_experiments.tools.passivity_oracle import DT, push_release_cycle, random_cycles, shipped_profiles

SHIPPED = shipped_profiles()
TRANSLATION = next(profile for name, profile in SHIPPED.items() if "replica.yaml:translation_" in name)
ROTATION = next(profile for name, profile in SHIPPED.items() if "replica.yaml:rotation_" in name)
#: The replica's translation profile before the passive attractor (F_max = 15 N), on which the literal reading of
#: Eq. 2 gave out 87.5 mJ on the push-release cycle.
OLD_TRANSLATION = ForceProfile(200.0, 0.05, 0.5, 15.0)


class LiteralEquationTwo(FractalAttractor):
    """The literal reading of Eq. 2, kept as the negative control: e_max latched at e_k on entering C, K_C =
    2 F_c(e_max)/e_max uncapped, and back to D (plain F_c, no dead zone) as soon as |e| grows: re-latching with no
    energy rule. Same snapshot layout as the passive attractor, so the observer-side storage reads it alike."""

    def _step(self, errors, rates):  # type: ignore[override]
        old = self._state
        profile = self._profile
        phases, latched, stiffness, forces = [], [], [], []
        for axis, (error, rate) in enumerate(zip(errors, rates)):
            magnitude_rate = math.copysign(1.0, error) * rate if error != 0.0 else 0.0
            converging, e_max, k_c = old[1][axis], old[2][axis], old[3][axis]
            if converging and not (magnitude_rate < 0.0 and error * e_max > 0.0):
                converging = False
            elif not converging and magnitude_rate < -self.rate_deadband and error != 0.0:
                converging, e_max = True, error
                k_c = 2.0 * abs(profile.scalar_force(error)) / abs(error)
            phases.append(converging)
            latched.append(e_max)
            stiffness.append(k_c)
            forces.append(k_c * (error - 0.5 * e_max) if converging else profile.scalar_force(error))
        self._state = type(old)(profile, tuple(phases), tuple(latched), tuple(stiffness), (0.0,) * len(errors),
                                tuple(errors), tuple(forces))
        return forces


def observe_cycle(attractor: FractalAttractor, errors: np.ndarray, rates: np.ndarray, dt: float = DT,
                  tolerance_j: float = 1e-6) -> ExchangedEnergyObserver:
    """Drive the attractor through the error cycle, the observer booking its force over the error's motion."""
    observer = ExchangedEnergyObserver(errors.shape[1], tolerance_j=tolerance_j, period_s=dt)
    storage = AttractorStorage(attractor.profile)
    attractor.reset()
    for error, rate in zip(errors, rates):
        force = attractor.force(error, rate)
        observer.observe(force, error, storage(attractor.snapshot()))
    return observer


def observe_orientation_loop(kind: str, amplitude: float, speed: float, dt: float, deadband: float,
                             tolerance_j: float = 1e-6) -> ExchangedEnergyObserver:
    """A closed orientation loop (orientation_loops); the port coordinate is the running sum of -phi_k (the target
    rests, so the energy into the controller over a step is -M . phi_k; the rate the law reads is -phi_{k-1}/dt)."""
    observer = ExchangedEnergyObserver(3, tolerance_j=tolerance_j, period_s=dt)
    storage = AttractorStorage(ROTATION)
    position = np.zeros(3)
    if kind == "angle_axis":
        attractor = RotationalAttractor(ROTATION, deadband)
        law, state = attractor.moment, (lambda: attractor.snapshot().scalar)
    else:
        attractor = FractalAttractor(ROTATION, 3, deadband)
        law, state = attractor.force, attractor.snapshot

    def observed(error: np.ndarray, rate: np.ndarray) -> np.ndarray:
        nonlocal position
        moment = law(error, rate)
        position = position + rate * dt
        observer.observe(moment, position, storage(state()))
        return moment

    run = drive_loop(observed, loop_rotation_vectors(amplitude, speed, dt), dt)
    assert observer.exchanged_work_j == pytest.approx(run.zoh_work, abs=1e-9)
    return observer


@pytest.mark.parametrize("amplitude", [0.5, 0.8, 1.2])
def test_it_flags_the_per_axis_rotation_on_closed_orientation_loops(amplitude: float) -> None:
    """Today's per-axis clamp on r, driven below the rate dead-band: energy out beyond storage and sampling, every
    loop, at 1 kHz and 100 Hz."""
    for dt, speed in ((1e-3, 0.3), (1e-2, 0.1)):
        observer = observe_orientation_loop("per_axis", amplitude, speed, dt, 1e3)
        assert observer.violation_ticks > 0, (amplitude, dt, observer.diagnostics())
        assert observer.min_margin_j < -0.05
        assert observer.margin_j < -0.05  # back at rest: the loop gave energy out


@pytest.mark.parametrize("dt", [1e-3, 1e-2], ids=["1kHz", "100Hz"])
@pytest.mark.parametrize("amplitude", [0.2, 0.5, 0.8, 1.2])
def test_it_passes_the_angle_axis_rotation(amplitude: float, dt: float) -> None:
    """The angle-axis FIC on the same loops, with and without switching: no violation beyond the sampling term
    (tolerance 1e-6 J); back at rest the exchanged work is >= 0 up to the held-moment shortfall."""
    for speed, deadband in ((1.0, 1e3), (0.3, 0.005), (1.5, 0.005)):
        observer = observe_orientation_loop("angle_axis", amplitude, speed, dt, deadband)
        assert observer.violation_ticks == 0, (amplitude, dt, speed, deadband, observer.diagnostics())
        assert observer.storage_j == 0.0
        assert observer.margin_j >= -observer.sampling_term_j - 1e-6


@pytest.mark.parametrize("speed", [0.02, 0.1, 0.5])
def test_it_flags_the_literal_switching_rule(speed: float) -> None:
    """The literal Eq. 2 reading on the push-release cycle (F_max = 15 N): the storage of its own declared state
    rises at its C -> D switches, the observer sees the energy come out."""
    errors, rates = push_release_cycle(speed, return_speed=0.002)  # the return below the dead-band: no C there
    observer = observe_cycle(LiteralEquationTwo(OLD_TRANSLATION, 1, 0.005), errors, rates)
    assert observer.violation_ticks > 0, observer.diagnostics()
    assert observer.exchanged_work_j < -0.05  # the closed cycle gave energy out (-87.5 mJ at 0.02 m/s)


@pytest.mark.parametrize("name", sorted(SHIPPED))
@pytest.mark.parametrize("speed", [0.02, 0.1, 0.5])
def test_it_passes_the_translational_attractor(name: str, speed: float) -> None:
    """The passive attractor on the same cycle (scaled to each shipped profile) and on the old F_max = 15 N
    profile: no violation; the storage here matches the attractor's own to 1e-8 J (checked at the end)."""
    for profile in (SHIPPED[name], OLD_TRANSLATION):
        scale = profile.saturation_error / 0.05
        errors, rates = push_release_cycle(speed)
        attractor = FractalAttractor(profile, 1, 0.005 * scale)
        observer = observe_cycle(attractor, errors * scale, rates * scale)
        assert observer.violation_ticks == 0, (name, speed, observer.diagnostics())
        assert observer.exchanged_work_j >= 0.0  # closed cycle from rest to rest
        assert observer.shortfall_j <= observer.sampling_term_j + 1e-9


def test_it_passes_random_cycles_on_three_axes() -> None:
    """Random cycles with reversals inside C, noise, sample-and-hold and wrong rates on three axes."""
    for seed in range(3):
        rng = np.random.default_rng(seed)
        errors, rates = random_cycles(rng, TRANSLATION.saturation_error, 3, 1500)
        attractor = FractalAttractor(TRANSLATION, 3, 0.005)
        observer = observe_cycle(attractor, errors, rates)
        assert observer.violation_ticks == 0, observer.diagnostics()
        assert abs(AttractorStorage(TRANSLATION)(attractor.snapshot()) - float(attractor.stored_energy.sum())) < 1e-8


def test_the_held_force_shortfall_and_the_damping_that_covers_it() -> None:
    """A linear spring F = k e driven out to a and back in steps of h, its force held over each step: by hand, every
    step short-changes the port by k h^2/2 (out: the force lags; back: it leads), so the margin ends at -k h a,
    the integral of |v|^2 is n h^2/dt after n steps, and the damping that covers the shortfall is k dt/2."""
    k, a, steps, dt = 200.0, 0.04, 400, 1e-3
    h = a / steps
    path = np.concatenate((np.arange(steps + 1) * h, (steps - 1 - np.arange(steps)) * h))
    observer = ExchangedEnergyObserver(1, tolerance_j=1e-9, period_s=dt)
    potential = ProfilePotential(ForceProfile(k, 1.0, 0.9, 0.9 * k))  # linear up to 0.9 m
    for e in path:
        observer.observe([k * e], [e], potential.energy(e))
    assert observer.exchanged_work_j == pytest.approx(-k * h * a, rel=1e-6)
    assert observer.min_margin_j == pytest.approx(-k * h * a, rel=1e-6)
    assert observer.shortfall_j == pytest.approx(k * h * a, rel=1e-6)
    assert observer.damping_needed == pytest.approx(k * dt / 2.0, rel=1e-6)
    # The sampling term (k h^2 a step) covers it: the spring is conservative, no violation.
    assert observer.sampling_term_j == pytest.approx(2 * k * h * a, rel=1e-6)
    assert observer.violation_ticks == 0
    # The same samples with the force of the step before last (a lag that makes it active): flagged.
    lagging = ExchangedEnergyObserver(1, tolerance_j=1e-9, period_s=dt)
    for index, e in enumerate(path):
        lagging.observe([k * path[max(index - 2, 0)]], [e], potential.energy(e))
    assert lagging.violation_ticks > 0
    keys = observer.diagnostics()
    assert set(keys) >= {"exchanged_work_j", "storage_j", "margin_j", "min_margin_j", "shortfall_j",
                         "damping_needed", "violation_ticks"} and all(isinstance(v, str) for v in keys.values())
    observer.reset()
    assert observer.ticks == 0 and observer.exchanged_work_j == 0.0 and observer.min_margin_j == 0.0


def test_the_profile_potential_is_the_integral_of_eq_1() -> None:
    for profile in SHIPPED.values():
        potential = ProfilePotential(profile)
        for fraction in (0.1, 0.5, 1.0, 2.0, 5.0):
            magnitude = fraction * profile.saturation_error
            assert potential.energy(magnitude) == pytest.approx(float(profile.energy(magnitude)),
                                                                abs=1e-8 * profile.max_force * profile.saturation_error)


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_bad_input_is_refused_in_one_line(bad: float) -> None:
    observer = ExchangedEnergyObserver(2)
    with pytest.raises(FicInputError, match="effort"):
        observer.observe([0.0, bad], [0.0, 0.0], 0.0)
    with pytest.raises(FicInputError, match="position"):
        observer.observe([0.0, 0.0], [bad, 0.0], 0.0)
    with pytest.raises(FicInputError, match="storage_j"):
        observer.observe([0.0, 0.0], [0.0, 0.0], bad)
    with pytest.raises(FicInputError, match="position"):
        observer.observe([0.0, 0.0], [0.0], 0.0)
    with pytest.raises(FicInputError, match="dof"):
        ExchangedEnergyObserver(0)
    with pytest.raises(FicInputError, match="period_s"):
        ExchangedEnergyObserver(1, period_s=0.0)
