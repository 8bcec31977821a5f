"""10,000 random error cycles at dt = 1 ms through the FIC attractor, judged by an independent storage.

Each cycle starts at rest at e = 0 and ends at rest there; its errors reverse inside C, carry noise, take both
signs, are sometimes sampled and held at 10 Hz, and come with rates that are right, noisy, reversed or unrelated
(passivity_oracle.py). Half the batches use the profiles shipped in config/, half random profiles.
Prints and (with --json) writes min over all samples of W_k - (V_k - V_0) [J] (target >= -1e-6 J), the
smallest closed-cycle work, the count of D -> C latches and of capped K_C.

With --orientation instead: closed orientation loops (orientation_loops.py) of 0.2-1.2 rad at 1 kHz,
500 Hz and 100 Hz, the held-moment work per loop of the angle-axis FIC (fic_core/rotational_attractor.py) and of
the old per-axis rule on the rotation vector, on the shipped rotation profile, below the rate dead-band.

With --held: the held-force shortfall of the FIC as the exchanged-energy observer books it
(fic_core/exchanged_energy_observer.py), at 1 kHz and 100 Hz: the push-release cycle and a figure eight on the
shipped translation, the closed orientation loops on the shipped rotation; work, shortfall, the damping that covers
it, violations.

With --strokes: 1, 3, 10 and 30 strokes between 40 and 33 mm at 0.02 m/s on the shipped translation, the force at
40 mm after them (and the dead zone, where the attractor has one: run it against an older fic_core on PYTHONPATH to
see the dead-zone rule's ratchet).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from fic_core.attractor import FractalAttractor
from fic_teleop_experiments.tools.passivity_oracle import (
    judge,
    random_cycles,
    random_profile,
    shipped_profiles,
    storage_for,
)


def orientation_table(speed: float) -> list[dict[str, float]]:
    """Held-moment work per closed orientation loop, angle-axis FIC against the old per-axis rule (no switching)."""
    from fic_core.rotational_attractor import RotationalAttractor
    from fic_teleop_experiments.tools.orientation_loops import drive_loop, loop_rotation_vectors

    profile = next(value for name, value in shipped_profiles().items() if "replica.yaml:rotation_" in name)
    rows = []
    for amplitude in (0.2, 0.5, 0.8, 1.2):
        for dt in (1e-3, 2e-3, 1e-2):
            vectors = loop_rotation_vectors(amplitude, speed, dt)
            new = RotationalAttractor(profile, 1e3)
            old = FractalAttractor(profile, 3, 1e3)
            new_run = drive_loop(new.moment, vectors, dt)
            old_run = drive_loop(old.force, vectors, dt)
            rows.append({"amplitude_rad": amplitude, "rate_hz": round(1.0 / dt), "speed_rad_s": speed,
                         "angle_axis_work_j": new_run.zoh_work, "per_axis_work_j": old_run.zoh_work,
                         "sampling_tolerance_j": new_run.sampling_tolerance})
    return rows


def held_table() -> list[dict[str, float | str]]:
    """Exchanged work, held-force shortfall and the damping that covers it, at 1 kHz and 100 Hz."""
    from fic_core.attractor_storage import AttractorStorage
    from fic_core.exchanged_energy_observer import ExchangedEnergyObserver
    from fic_core.rotational_attractor import RotationalAttractor
    from fic_teleop_experiments.tools.orientation_loops import drive_loop, loop_rotation_vectors
    from fic_teleop_experiments.tools.passivity_oracle import push_release_cycle

    profiles = shipped_profiles()
    translation = next(value for name, value in profiles.items() if "replica.yaml:translation_" in name)
    rotation = next(value for name, value in profiles.items() if "replica.yaml:rotation_" in name)
    rows: list[dict[str, float | str]] = []

    def translational(name: str, errors: np.ndarray, rates: np.ndarray, dt: float) -> None:
        attractor = FractalAttractor(translation, errors.shape[1], 0.005)
        observer = ExchangedEnergyObserver(errors.shape[1], tolerance_j=1e-6, period_s=dt)
        storage = AttractorStorage(translation)
        for error, rate in zip(errors, rates):
            observer.observe(attractor.force(error, rate), error, storage(attractor.snapshot()))
        rows.append({"cycle": name, "rate_hz": round(1.0 / dt), "work_j": observer.exchanged_work_j,
                     "shortfall_j": observer.shortfall_j, "damping_needed": observer.damping_needed,
                     "violations": observer.violation_ticks})

    for dt in (1e-3, 1e-2):
        errors, rates = push_release_cycle(0.1, dt=dt)
        translational("push-release 0.1 m/s", errors, rates, dt)
        for frequency in (1.0, 5.0):
            # A figure eight of 0.1 m in x-y (x at f, y at 2 f) for 3 periods from rest, then back to rest.
            time = np.arange(0.0, 3.0 / frequency, dt)
            ramp = np.minimum(1.0, np.minimum(time, time[-1] - time) * frequency)  # in and out over one period
            phase = 2.0 * np.pi * frequency * time
            errors = np.stack((0.1 * ramp * np.sin(phase), 0.05 * ramp * np.sin(2.0 * phase), 0.0 * time), axis=1)
            rates = np.gradient(errors, dt, axis=0)
            translational(f"figure eight 0.1 m {frequency:g} Hz", errors, rates, dt)
        for amplitude in (0.5, 1.2):
            attractor = RotationalAttractor(rotation, 0.005)
            observer = ExchangedEnergyObserver(3, tolerance_j=1e-6, period_s=dt)
            storage = AttractorStorage(rotation)
            position = np.zeros(3)

            def observed(error: np.ndarray, rate: np.ndarray) -> np.ndarray:
                nonlocal position
                moment = attractor.moment(error, rate)  # noqa: B023
                position = position + rate * dt  # noqa: B023
                observer.observe(moment, position, storage(attractor.snapshot().scalar))  # noqa: B023
                return moment

            drive_loop(observed, loop_rotation_vectors(amplitude, 1.0, dt), dt)
            rows.append({"cycle": f"orientation loop {amplitude:g} rad 1 rad/s", "rate_hz": round(1.0 / dt),
                         "work_j": observer.exchanged_work_j, "shortfall_j": observer.shortfall_j,
                         "damping_needed": observer.damping_needed, "violations": observer.violation_ticks})
    return rows


def stroke_table() -> list[dict[str, float]]:
    """The force at 40 mm after n strokes 40 -> 33 -> 40 mm at 0.02 m/s, dt = 1 ms, shipped translation."""
    profile = next(value for name, value in shipped_profiles().items() if "replica.yaml:translation_" in name)
    rows = []
    for count in (1, 3, 10, 30):
        attractor = FractalAttractor(profile, 1, 0.005)
        knots = [0.0, 0.040] + [0.033, 0.040] * count
        force = 0.0
        for first, last in zip(knots[:-1], knots[1:]):
            steps = int(round(abs(last - first) / 2e-5))
            for index in range(1, steps + 1):
                force = float(attractor.force([first + (last - first) * index / steps],
                                              [0.02 if last > first else -0.02])[0])
        rows.append({"strokes": count, "force_at_40mm_n": force, "profile_force_at_40mm_n": float(profile.force(0.04)),
                     "dead_zone_mm": 1e3 * float(getattr(attractor, "dead_zone", [0.0])[0])})
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--orientation", action="store_true", help="the closed orientation loops instead")
    parser.add_argument("--speed", type=float, default=0.1, help="with --orientation: loop speed [rad/s]")
    parser.add_argument("--strokes", action="store_true", help="the force at 40 mm after strokes instead")
    parser.add_argument("--held", action="store_true", help="the held-force shortfall at 1 kHz and 100 Hz instead")
    parser.add_argument("--cycles", type=int, default=10_000)
    parser.add_argument("--axes", type=int, default=10, help="cycles run side by side on one profile")
    parser.add_argument("--samples", type=int, default=1000, help="samples per cycle (dt = 1 ms)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path)
    arguments = parser.parse_args(argv)
    if arguments.held:
        rows = held_table()
        for row in rows:
            print(" ".join(f"{key}={value:.4g}" if isinstance(value, float) else f"{key}={value}"
                           for key, value in row.items()))
        if arguments.json:
            arguments.json.write_text(json.dumps(rows, indent=2) + "\n")
        return 0 if all(row["violations"] == 0 for row in rows) else 1
    if arguments.strokes:
        for row in stroke_table():
            print(" ".join(f"{key}={value:.4g}" for key, value in row.items()))
        return 0
    if arguments.orientation:
        rows = orientation_table(arguments.speed)
        for row in rows:
            print(" ".join(f"{key}={value:.4g}" for key, value in row.items()))
        if arguments.json:
            arguments.json.write_text(json.dumps(rows, indent=2) + "\n")
        return 0 if all(row["angle_axis_work_j"] >= -row["sampling_tolerance_j"] for row in rows) else 1
    rng = np.random.default_rng(arguments.seed)
    shipped = list(shipped_profiles().values())
    began = time.monotonic()
    worst_margin = worst_scaled = worst_cycle = np.inf
    latches = capped = batches = 0
    shipped_worst = np.inf
    while batches * arguments.axes < arguments.cycles:
        use_shipped = batches % 2 == 0
        profile = shipped[(batches // 2) % len(shipped)] if use_shipped else random_profile(rng)
        errors, rates = random_cycles(rng, profile.saturation_error, arguments.axes, arguments.samples)
        deadband = float(rng.choice([0.0, 0.005, 0.05])) * profile.saturation_error / 0.05
        verdict = judge(FractalAttractor(profile, arguments.axes, deadband), errors, rates,
                        storage_for(profile, errors))
        scale = max(1.0, profile.max_force * profile.saturation_error)
        worst_margin = min(worst_margin, verdict.min_margin)
        worst_scaled = min(worst_scaled, verdict.min_margin / scale)
        if use_shipped:
            shipped_worst = min(shipped_worst, verdict.min_margin)
        worst_cycle = min(worst_cycle, float(np.min(verdict.final_work)))
        latches += verdict.latches
        capped += verdict.capped_latches
        batches += 1
    result = {"cycles": batches * arguments.axes, "dt_s": 1e-3, "samples_per_cycle": arguments.samples,
              "min_margin_j": worst_margin, "min_margin_shipped_profiles_j": shipped_worst,
              "min_margin_per_max_force_x_b": worst_scaled, "min_closed_cycle_work_j": worst_cycle,
              "latches": latches, "capped_latches": capped, "seconds": round(time.monotonic() - began, 1)}
    print(json.dumps(result, indent=2))
    if arguments.json:
        arguments.json.write_text(json.dumps(result, indent=2) + "\n")
    return 0 if worst_scaled >= -1e-6 and shipped_worst >= -1e-6 else 1


if __name__ == "__main__":
    sys.exit(main())
