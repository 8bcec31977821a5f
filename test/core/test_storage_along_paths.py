"""The attractors' stored energy is the work of their force along the path, step by step, on random paths in
translation and rotation (docs/CONTROL_LAWS.md, "Passivity of the attractor" and "Rotation").

Each phase's force is the gradient of its storage, so between two samples in one phase the storage changes by the
integral of force times displacement. The test integrates that work itself, by the trapezoid rule on the forces
the attractor returned at the two samples, whose error on a field of Lipschitz constant L over a displacement d
is at most L d^2 / 4. A switch D -> C keeps the storage at the previous sample (the latch) and so the same
equality holds up to the force's jump there; a switch C -> D may only lose storage (the difference is what the
FIC dissipates): there the storage's change is at most the work. Nothing is read from the attractor but its force,
its storage and its phase.
"""
from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.attractor import FractalAttractor
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.rotational_attractor import RotationalAttractor
from fic_teleop_experiments.tools.passivity_oracle import random_profile, shipped_profiles

DT = 1e-3
SHIPPED = list(shipped_profiles().values())


def random_path(rng, scale: float, dimensions: int, samples: int) -> np.ndarray:
    """A path from rest at 0: velocities of a random smooth process (ramps toward random targets within 2.5
    ``scale`` with reversals, at speeds up to 4 ``scale``/s), so that axes swing out, turn and cross zero."""
    path = np.zeros((samples, dimensions))
    target = rng.uniform(-2.5, 2.5, dimensions) * scale
    speed = rng.uniform(0.5, 4.0) * scale
    for k in range(1, samples):
        if rng.random() < 0.004:
            target = rng.uniform(-2.5, 2.5, dimensions) * scale
            speed = rng.uniform(0.5, 4.0) * scale
        towards = target - path[k - 1]
        step = towards / max(np.linalg.norm(towards) / (speed * DT), 1.0)
        path[k] = path[k - 1] + step + rng.normal(scale=0.02 * speed * DT, size=dimensions)
    return path


def check_work(path: np.ndarray, step, ports: list[tuple[slice, float, float]]) -> list[dict[str, int]]:
    """Drive ``step(error, rate) -> (force, storages, phases)`` along ``path`` (rates: the path's differences) and
    check each port's storage change against the trapezoid of its force times its displacement. ``ports``: the
    error slice, the field's Lipschitz constant and F_max of each port. Returns, per port, how many steps it
    spent in C and how often it entered and left C."""
    counts = [{"steps in C": 0, "into C": 0, "out of C": 0} for _ in ports]
    previous_error = path[0]
    force, storages, phases = step(path[0], np.zeros(path.shape[1]))
    for error in path[1:]:
        new_force, new_storages, new_phases = step(error, (error - previous_error) / DT)
        for port, (axes, lipschitz, max_force) in enumerate(ports):
            displacement = error[axes] - previous_error[axes]
            distance = float(np.linalg.norm(displacement))
            work = 0.5 * float((force[axes] + new_force[axes]) @ displacement)
            change = new_storages[port] - storages[port]
            bound = lipschitz * distance * distance / 4.0 + 1e-12 * (1.0 + abs(storages[port]))
            entered, left = new_phases[port] and not phases[port], phases[port] and not new_phases[port]
            if entered:
                bound += 0.5 * distance * max_force   # the force may jump at the latch (K_C's energy cap)
            if left:
                assert change <= work + bound, (port, change, work)
            else:
                assert abs(change - work) <= bound, (port, change, work, bound, phases[port], new_phases[port])
            counts[port]["steps in C"] += bool(new_phases[port])
            counts[port]["into C"] += entered
            counts[port]["out of C"] += left
        previous_error, force, storages, phases = error, new_force, new_storages, new_phases
    return counts


def translation_step(attractor: FractalAttractor):
    def step(error, rate):
        force = attractor.force(error, rate)
        return force, attractor.stored_energy.tolist(), attractor.phase.tolist()
    return step


@settings(max_examples=12, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), which=st.integers(0, 99), deadband=st.sampled_from([0.0, 0.005, 0.05]))
def test_translation_storage_changes_by_the_work_of_the_force(seed: int, which: int, deadband: float) -> None:
    rng = np.random.default_rng(seed)
    profile = SHIPPED[which % len(SHIPPED)] if which < 50 else random_profile(rng)
    attractor = FractalAttractor(profile, 3, deadband)
    lipschitz = 2.0 * profile.lipschitz_bound()   # K_C <= 2 F(e_max)/e_max <= 2 max slope
    path = random_path(rng, profile.saturation_error, 3, 1500)
    counts = check_work(path, translation_step(attractor),
                        [(slice(axis, axis + 1), lipschitz, profile.max_force) for axis in range(3)])
    assert sum(port["into C"] for port in counts) > 0, counts


def test_translation_paths_reach_every_switch() -> None:
    """The paths above do swing into C, stay there, and leave it, on the shipped profiles."""
    totals = {"steps in C": 0, "into C": 0, "out of C": 0}
    for seed, profile in enumerate(SHIPPED):
        rng = np.random.default_rng(seed)
        attractor = FractalAttractor(profile, 3)
        counts = check_work(random_path(rng, profile.saturation_error, 3, 1500), translation_step(attractor),
                            [(slice(axis, axis + 1), 2.0 * profile.lipschitz_bound(), profile.max_force)
                             for axis in range(3)])
        totals = {name: totals[name] + sum(port[name] for port in counts) for name in totals}
    assert totals["into C"] >= 10 and totals["out of C"] >= 10 and totals["steps in C"] > 500, totals


def rotation_path(rng, scale: float, samples: int) -> np.ndarray:
    """A random path of rotation vectors kept away from 0 (where the C field's direction is undefined) and from
    pi (the cut locus of log3), swinging the angle in and out."""
    path = random_path(rng, scale, 3, samples)
    path[:, 0] += 1.2 * scale   # off the origin on one side
    angles = np.linalg.norm(path, axis=1, keepdims=True)
    return np.where(angles > 3.0, path * 3.0 / angles, path)


def rotation_ports(profile: ForceProfile, path: np.ndarray, axes: slice) -> tuple[slice, float, float]:
    """The moment r/|r| F(|r|) has Hessian eigenvalues F'(|r|) and F(|r|)/|r|: bounded by 2 L, and in C by
    F_max over the smallest angle of the path."""
    smallest = float(np.linalg.norm(path[:, axes], axis=1).min())
    return axes, max(2.0 * profile.lipschitz_bound(), profile.max_force / (smallest - 0.01)), profile.max_force


def rotation_work(seed: int, which: int) -> dict[str, int]:
    """``check_work`` of a RotationalAttractor on a random rotation path (a shipped or random profile)."""
    rng = np.random.default_rng(seed)
    profile = SHIPPED[which % len(SHIPPED)] if which < 50 else random_profile(rng)
    path = rotation_path(rng, min(profile.saturation_error, 0.8), 1500)
    attractor = RotationalAttractor(profile)

    def step(error, rate):
        moment = attractor.moment(error, rate)
        return moment, [float(attractor.stored_energy.sum())], [int(attractor.phase[0])]

    return check_work(path, step, [rotation_ports(profile, path, slice(0, 3))])[0]


@settings(max_examples=10, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), which=st.integers(0, 99))
def test_rotation_storage_changes_by_the_work_of_the_moment(seed: int, which: int) -> None:
    rotation_work(seed, which)


def test_rotation_paths_reach_every_switch() -> None:
    totals = {"steps in C": 0, "into C": 0, "out of C": 0}
    for seed in range(4):
        counts = rotation_work(seed, seed)
        totals = {name: totals[name] + counts[name] for name in totals}
    assert totals["into C"] >= 5 and totals["out of C"] >= 5 and totals["steps in C"] > 200, totals


def test_the_pose_attractor_stores_the_work_of_its_wrench_in_translation_and_rotation() -> None:
    """The PoseAttractor's six components on one random path each: three translational ports and the angle's."""
    totals = [{"steps in C": 0, "into C": 0, "out of C": 0} for _ in range(4)]
    for seed in range(4):
        rng = np.random.default_rng(100 + seed)
        translation, rotation = SHIPPED[seed % len(SHIPPED)], ForceProfile(20.0, 0.5, 0.5, 10.0)
        attractor = PoseAttractor(translation, rotation)
        path = np.hstack([random_path(rng, translation.saturation_error, 3, 1500),
                          rotation_path(rng, 0.5, 1500)])

        def step(error, rate, attractor=attractor):
            wrench = attractor.wrench(error[:3], error[3:], rate)
            energy, phase = attractor.stored_energy, attractor.phase
            return wrench, [*energy[:3].tolist(), float(energy[3:].sum())], [*phase[:3].tolist(), int(phase[3])]

        ports = [(slice(axis, axis + 1), 2.0 * translation.lipschitz_bound(), translation.max_force)
                 for axis in range(3)] + [rotation_ports(rotation, path, slice(3, 6))]
        counts = check_work(path, step, ports)
        totals = [{name: total[name] + port[name] for name in total} for total, port in zip(totals, counts)]
    # Both kinds of switch, in translation and in rotation (the angle's port is the fourth).
    assert sum(port["into C"] for port in totals[:3]) >= 5 and totals[3]["into C"] >= 2, totals
    assert sum(port["out of C"] for port in totals[:3]) >= 5 and totals[3]["out of C"] >= 2, totals
