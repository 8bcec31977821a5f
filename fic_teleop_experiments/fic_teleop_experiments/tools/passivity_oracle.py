"""An independent judge of the attractor's passivity: random error cycles, the port work, and a storage of its own.

The attractor (fic_core/attractor.py) claims, for every input sequence, ``V_k - V_0 <= W_k`` with the sampled
port work ``W_k = sum_j F_j (e_j - e_{j-1})`` (docs/CONTROL_LAWS.md, "Passivity of the attractor"). This module
checks the claim without trusting the attractor's own energy functions:

* the work is summed here from the forces the attractor returned;
* the storage is computed here: V_D by numerical quadrature of the profile (a cumulative Simpson table of
  F_c, checked against ``scipy.integrate.quad``), V_C by the exact trapezoid of the clipped linear C force split
  at its kinks, V_latch from this module's own V_D at the latch. Only the attractor's discrete state is read
  (phase, e_max, K_C), and the forces it returned are checked against the force law of that state,
  so the storage judged here is the true potential of the forces that were applied.

Used by test/core/test_passivity.py (a few hundred cycles) and passivity_cycles.py (10,000).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import yaml
from scipy.integrate import cumulative_simpson, quad

from fic_core.attractor import FractalAttractor
from fic_core.profile import ForceProfile
from fic_teleop_runtime.workspace import config_folder

DT = 1e-3  #: the replica's control period [s]


def shipped_profiles() -> dict[str, ForceProfile]:
    """Every FIC force profile in config/*.yaml (replica translation and rotation, master, and any other file
    whose parameters carry the profile's four names with a common prefix)."""
    names = ("stiffness", "saturation_error", "saturation_start", "max_force")
    found: dict[str, ForceProfile] = {}
    config = config_folder()
    for path in sorted(config.rglob("*.yaml")):
        document = yaml.safe_load(path.read_text()) or {}
        for _node, body in document.items():
            parameters = (body or {}).get("ros__parameters", {}) if isinstance(body, dict) else {}
            for key, _value in parameters.items():
                if not key.endswith("saturation_error"):
                    continue
                prefix = key[: -len("saturation_error")]
                values = [parameters.get(prefix + name) for name in names]
                if all(isinstance(item, (int, float)) for item in values):
                    found[f"config/{path.relative_to(config)}:{prefix or 'fic_'}"] = ForceProfile(*map(float, values))
    return found


def random_profile(rng: np.random.Generator) -> ForceProfile:
    """Any admissible profile: stiff or soft, xi from 0, F_max from F0 (a flat clamp) to three times K0 x_b."""
    stiffness = float(rng.uniform(5.0, 5000.0))
    saturation_error = float(rng.uniform(0.002, 1.0))
    saturation_start = 0.0 if rng.random() < 0.2 else float(rng.uniform(0.0, 0.95))
    start_force = saturation_start * stiffness * saturation_error
    max_force = start_force + (0.0 if rng.random() < 0.1 else float(rng.uniform(0.0,
                                                                                3.0)) * stiffness * saturation_error)
    return ForceProfile(stiffness, saturation_error, saturation_start, max(max_force, 1e-9))


def random_cycles(rng: np.random.Generator, scale: float, axes: int, samples: int) -> tuple[np.ndarray, np.ndarray]:
    """``axes`` random error cycles of ``samples`` samples at DT, each from rest at 0 back to rest at 0.

    Piecewise-smooth segments (ramps and half-sines between random knots of both signs within 2.5 ``scale``, so
    that the axis reverses inside C), optionally with noise, a 10 Hz sample-and-hold, and rates that are the
    true derivative, a noisy one, its opposite, or unrelated noise. The last 20 % returns slowly to 0 and rests.
    Returns (errors, rates), each (samples, axes).
    """
    body = int(samples * 0.8)
    errors = np.zeros((samples, axes))
    rates = np.zeros((samples, axes))
    for axis in range(axes):
        knots = int(rng.integers(3, 12))
        times = np.sort(rng.choice(np.arange(1, body - 1), size=knots, replace=False))
        times = np.concatenate(([0], times, [body - 1]))
        values = np.concatenate(([0.0], rng.uniform(-2.5, 2.5, size=knots) * scale, [rng.uniform(-1, 1) * scale]))
        path = np.empty(body)
        for begin, end, first, last in zip(times[:-1], times[1:], values[:-1], values[1:]):
            fraction = np.linspace(0.0, 1.0, end - begin + 1)
            shape = fraction if rng.random() < 0.5 else 0.5 - 0.5 * np.cos(np.pi * fraction)
            path[begin:end + 1] = first + (last - first) * shape
        mode = rng.random()
        if mode < 0.3:
            path = path + rng.normal(0.0, 0.02 * scale, body) * (np.arange(body) > 0)
        if rng.random() < 0.3:  # a 10 Hz sample-and-hold of the error (100 samples at 1 kHz)
            path = path[(np.arange(body) // 100) * 100]
        derivative = np.gradient(path, DT)
        rate_mode = rng.random()
        if rate_mode < 0.4:
            rate = derivative
        elif rate_mode < 0.6:
            rate = derivative + rng.normal(0.0, 0.5 * scale / 0.05, body)
        elif rate_mode < 0.8:
            rate = -derivative
        else:
            rate = rng.normal(0.0, scale / 0.05, body)
        # The return: slowly to 0 (a tenth of the body's length), then at rest.
        back = samples - body
        ramp = max(1, back // 2)
        tail = np.concatenate((path[-1] * (1.0 - np.arange(1, ramp + 1) / ramp), np.zeros(back - ramp)))
        tail_rate = np.concatenate((np.full(ramp, -path[-1] / (ramp * DT)), np.zeros(back - ramp)))
        errors[:, axis] = np.concatenate((path, tail))
        rates[:, axis] = np.concatenate((rate, tail_rate))
    errors[0] = 0.0
    rates[0] = 0.0
    return errors, rates


class DivergenceStorage:
    """V_D(a) = integral_0^a F_c by a cumulative Simpson table of the profile on [0, reach], linear beyond."""

    def __init__(self, profile: ForceProfile, reach: float, points: int = 400_001) -> None:
        self.grid = np.linspace(0.0, reach, points)
        self.forces = profile.force(self.grid)
        self.table = np.concatenate(([0.0], cumulative_simpson(self.forces, x=self.grid)))
        self.reach = reach
        self.profile = profile

    def __call__(self, magnitude: np.ndarray) -> np.ndarray:
        magnitude = np.maximum(np.asarray(magnitude, dtype=float), 0.0)
        clipped = np.minimum(magnitude, self.reach)
        step = self.grid[1]
        index = np.minimum((clipped / step).astype(np.int64), self.grid.size - 2)
        offset = clipped - self.grid[index]
        # Between grid points F_c is taken as linear: the table value plus the exact integral of that line.
        slope = (self.forces[index + 1] - self.forces[index]) / step
        inside = self.table[index] + self.forces[index] * offset + 0.5 * slope * offset * offset
        beyond = magnitude - clipped
        # Beyond the table (>= 4 x_b) F_c is within rounding of F_max.
        return inside + beyond * self.profile.max_force

    def quad_check(self, magnitudes: np.ndarray) -> float:
        """Largest |table - scipy.integrate.quad| over the magnitudes [J]."""
        force = self.profile.scalar_force
        limit = self.profile.linear_limit
        worst = 0.0
        for magnitude in magnitudes:
            points = [limit] if 0.0 < limit < magnitude else None
            exact = quad(force, 0.0, float(magnitude), points=points, limit=200, epsabs=1e-13)[0]
            worst = max(worst, abs(float(self(np.array([magnitude]))[0]) - exact))
        return worst


def clipped_linear_integral(stiffness: np.ndarray, centre: np.ndarray, clip: float, start: np.ndarray,
                            end: np.ndarray) -> np.ndarray:
    """integral_start^end clip(K (s - centre), +-clip) ds per axis, exact: the trapezoid of a piecewise-linear
    function over its pieces (the interval split at the kinks centre +- clip/K)."""
    stiffness = np.asarray(stiffness, dtype=float)
    safe = np.where(stiffness > 0.0, stiffness, 1.0)
    low, high = np.minimum(start, end), np.maximum(start, end)
    kinks = np.stack((centre - clip / safe, centre + clip / safe))
    cuts = np.sort(np.vstack((low, np.clip(kinks, low, high), high)), axis=0)  # (4, axes)
    values = np.clip(stiffness * (cuts - centre), -clip, clip)
    total = np.sum(0.5 * (values[1:] + values[:-1]) * np.diff(cuts, axis=0), axis=0)
    return np.where(stiffness > 0.0, np.where(end >= start, total, -total), 0.0)


@dataclass
class CycleVerdict:
    min_margin: float          #: min over samples and axes of W_k - (V_k - V_0), this module's storage [J]
    final_work: np.ndarray     #: W over each closed cycle [J] (axes,)
    forward_min_margin: float  #: the same with the forward (zero-order-hold) sum F_{j-1} (e_j - e_{j-1}) [J]
    storage_gap: float         #: max |V_attractor - V_here| [J]
    max_force: float           #: max |F| returned [N]
    convergence_ticks: int     #: samples spent in C (so that a run that never entered C is visible)
    latches: int               #: D -> C switches
    capped_latches: int        #: of those, where K_C's cap (8 V/e_max^2) was below 2 F/e_max


def judge(attractor: FractalAttractor, errors: np.ndarray, rates: np.ndarray,
          storage: DivergenceStorage) -> CycleVerdict:
    """Run the attractor over the cycles and judge it with this module's storage (module docstring)."""
    profile = attractor.profile
    max_force = profile.max_force
    axes = errors.shape[1]
    attractor.reset()
    work = np.zeros(axes)
    forward_work = np.zeros(axes)
    previous_error = np.zeros(axes)
    previous_force = np.zeros(axes)
    latched_energy = np.zeros(axes)
    previous_state = attractor.snapshot()
    min_margin = forward_min = np.inf
    storage_gap = 0.0
    peak = 0.0
    convergence_ticks = latches = capped = 0
    for error, rate in zip(errors, rates):
        force = attractor.force(error, rate)
        state = attractor.snapshot()
        phase = np.array(state.in_convergence)
        was = np.array(previous_state.in_convergence)
        latched = np.array(state.latched_max_errors)
        stiffness = np.array(state.convergence_stiffness)
        entering = phase & ~was
        if entering.any():
            assert np.all(latched[entering] == previous_error[entering]), "e_max is not e_{k-1}"
            reach = np.abs(previous_error[entering])
            latched_energy[entering] = storage(reach)
            latched_force = np.abs(profile.force(reach))
            magnitude = np.abs(latched[entering])
            paper = 2.0 * latched_force / magnitude
            cap = 8.0 * latched_energy[entering] / magnitude ** 2
            np.testing.assert_allclose(stiffness[entering], np.minimum(paper, cap), rtol=1e-6,
                                       atol=1e-6 * profile.stiffness)
            latches += int(entering.sum())
            capped += int(np.sum(cap < paper * (1 - 1e-9)))
        # The force must be the force law of the state (so V below is its potential).
        divergence = profile.force(error)
        convergence = np.clip(stiffness * (error - 0.5 * latched), -max_force, max_force)
        expected = np.where(phase, convergence, divergence)
        np.testing.assert_allclose(force, expected, rtol=1e-9, atol=1e-12 * max_force)
        # This module's storage.
        divergence_storage = storage(np.abs(error))
        convergence_storage = latched_energy + clipped_linear_integral(stiffness, 0.5 * latched, max_force, latched,
                                                                       error)
        value = np.where(phase, convergence_storage, divergence_storage)
        work += force * (error - previous_error)
        forward_work += previous_force * (error - previous_error)
        min_margin = min(min_margin, float(np.min(work - value)))
        forward_min = min(forward_min, float(np.min(forward_work - value)))
        storage_gap = max(storage_gap, float(np.max(np.abs(attractor.stored_energy - value))))
        peak = max(peak, float(np.max(np.abs(force))))
        convergence_ticks += int(phase.sum())
        previous_error, previous_force, previous_state = error.copy(), force.copy(), state
    return CycleVerdict(min_margin, work, forward_min, storage_gap, peak, convergence_ticks, latches, capped)


def storage_for(profile: ForceProfile, errors: np.ndarray) -> DivergenceStorage:
    return DivergenceStorage(profile, max(4.0 * profile.saturation_error, 1.01 * float(np.max(np.abs(errors)))))


def push_release_cycle(speed: float, dt: float = DT, far: float = 0.04, near: float = 0.028, repeats: int = 5,
                       return_speed: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """One axis driven as an environment can drive it, from rest at e = 0: out to ``far`` at ``speed``, back to
    ``near`` (the axis enters C and latches e_max = far), out to ``far`` again (C -> D), ``repeats`` times, then
    back to 0 at ``return_speed``, the error rate always the true one. Returns (errors, rates), each (n, 1)."""
    knots = [0.0, far] + [near, far] * repeats
    errors, rates = [0.0], [0.0]
    for first, last in zip(knots[:-1], knots[1:]):
        steps = max(1, int(round(abs(last - first) / (speed * dt))))
        errors += [first + (last - first) * index / steps for index in range(1, steps + 1)]
        rates += [np.sign(last - first) * speed] * steps
    steps = int(round(far / (return_speed * dt)))
    errors += [far * (1.0 - index / steps) for index in range(1, steps + 1)]
    rates += [-return_speed] * steps
    errors.append(0.0)
    rates.append(0.0)
    return np.array(errors)[:, None], np.array(rates)[:, None]
