"""An AttractorSnapshot's named fields read what it was built with, each under its own name (the snapshot is a
tuple underneath: a wrong slot would hand the phase logic, the passivity observer or the report another field);
and its derived values (storage, port values, phase stiffness) read the fields by those meanings, checked on a real
attractor in C against the module's own storage function."""
from __future__ import annotations

import inspect

import numpy as np
import pytest

from fic_core.attractor import AttractorSnapshot, FractalAttractor, Phase, convergence_storage
from fic_core.profile import ForceProfile

PROFILE = ForceProfile(200.0, 0.05, 0.5, 10.0)


def test_each_named_field_reads_the_value_given_under_its_name() -> None:
    names = list(inspect.signature(AttractorSnapshot.__new__).parameters)[1:]
    assert names == ["profile", "in_convergence", "latched_max_errors", "convergence_stiffness", "latched_energies",
                     "errors", "forces"]
    values = {name: (object(),) if name != "profile" else PROFILE for name in names}
    snapshot = AttractorSnapshot(**values)
    for name in names:
        assert getattr(snapshot, name) is values[name], name


def attractor_in_convergence() -> tuple[FractalAttractor, list[float]]:
    """Axis 0 grows to 40 mm (D) then shrinks (C); axis 1 grows (D); axis 2 at rest."""
    attractor = FractalAttractor(PROFILE, 3, rate_deadband=0.001)
    forces = []
    for error, rate in ((0.02, 0.5), (0.04, 0.5), (0.035, -0.5), (0.03, -0.5)):
        forces = attractor.force(np.array([error, 0.5 * error, 0.0]), np.array([rate, 0.5, 0.0])).tolist()
    return attractor, forces


def test_a_snapshot_in_convergence_reports_its_own_phase_latch_error_and_force() -> None:
    attractor, forces = attractor_in_convergence()
    snapshot = attractor.snapshot()
    assert snapshot.profile is PROFILE
    assert snapshot.in_convergence == (True, False, False)
    assert snapshot.phase.tolist() == [Phase.CONVERGENCE, Phase.DIVERGENCE, Phase.DIVERGENCE]
    assert snapshot.latched_max_errors == (0.04, 0.0, 0.0)   # e_max: e_{k-1} when axis 0 entered C
    assert snapshot.latched_max_error.tolist() == [0.04, 0.0, 0.0]
    assert snapshot.errors == (0.03, 0.015, 0.0)
    assert list(snapshot.forces) == forces
    assert snapshot.last_force.tolist() == forces
    # V_latch: the storage V_D(e_max) at the switch; K_C = min(2 F_c(e_max)/e_max, 8 V_latch/e_max^2) (Eq. 2).
    assert snapshot.latched_energies == (PROFILE.scalar_energy(0.04), 0.0, 0.0)
    assert snapshot.convergence_stiffness[0] == pytest.approx(
        min(2.0 * PROFILE.scalar_force(0.04) / 0.04, 8.0 * PROFILE.scalar_energy(0.04) / 0.04 ** 2), rel=1e-12)
    assert forces[0] == pytest.approx(snapshot.convergence_stiffness[0] * (0.03 - 0.02), rel=1e-12)


def test_derived_values_read_the_fields_by_their_meaning() -> None:
    attractor, _ = attractor_in_convergence()
    snapshot = attractor.snapshot()
    storage = [convergence_storage(PROFILE, snapshot.latched_max_errors[0], snapshot.convergence_stiffness[0],
                                   snapshot.latched_energies[0], snapshot.errors[0]),
               PROFILE.scalar_energy(snapshot.errors[1]), 0.0]
    assert snapshot.storage_values() == storage
    assert snapshot.stored_energy.tolist() == storage
    assert snapshot.port_values() == (snapshot.errors, snapshot.forces, storage)
    assert snapshot.phase_stiffness(0) == snapshot.convergence_stiffness[0] != PROFILE.stiffness
    assert snapshot.phase_stiffness(1) == PROFILE.stiffness
