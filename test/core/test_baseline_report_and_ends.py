"""The linear baseline reports as the FIC does (six slots of the FicState message: no phase, nothing latched, the
spring's storage K e^2/2), before its first wrench and after a reset too; and its parameters are accepted to the
ends of their ranges (a mass, an inertia or a force bound below one unit, a zero damping ratio) and refused past
them, in one line naming the parameter."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.baseline import LinearImpedance, make_baseline_like
from fic_core.errors import FicInputError
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile

FIC = PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 10.0), ForceProfile(20.0, 0.5, 0.5, 5.0))


def test_before_any_wrench_and_after_a_reset_the_six_slots_are_at_rest() -> None:
    baseline = LinearImpedance(200.0, 20.0, 39.6, 1.98)
    for _ in range(2):
        snapshot = baseline.snapshot()
        assert snapshot.phase.tolist() == [0] * 6 and snapshot.latched_max_error.tolist() == [0.0] * 6
        assert snapshot.last_force.tolist() == [0.0] * 6
        assert snapshot.port_values() == ((0.0,) * 6, (0.0,) * 6, [0.0] * 6)
        baseline.wrench([0.01, -0.02, 0.0], [0.0, 0.1, 0.0], np.zeros(6))
        snapshot = baseline.snapshot()
        assert snapshot.phase.shape == (6,) and snapshot.latched_max_error.shape == (6,)
        errors, forces, storages = snapshot.port_values()
        assert errors == (0.01, -0.02, 0.0, 0.0, 0.1, 0.0)
        assert storages == pytest.approx([0.01, 0.04, 0.0, 0.0, 0.1, 0.0], rel=1e-12)   # K e^2 / 2
        baseline.reset()


def test_the_parameters_are_accepted_to_the_ends_of_their_ranges() -> None:
    baseline = make_baseline_like(FIC, damping_ratio=0.0, effective_mass=0.5, effective_inertia=0.05)
    assert baseline.damping.tolist() == [0.0] * 6
    baseline = make_baseline_like(FIC, damping_ratio=0.7, effective_mass=0.5, effective_inertia=0.05)
    assert baseline.damping[0] == pytest.approx(1.4 * np.sqrt(200.0 * 0.5))
    bounded = LinearImpedance(200.0, 20.0, 0.0, 0.0, max_force=(0.5, 0.25))
    wrench = bounded.wrench([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], np.zeros(6))
    assert np.linalg.norm(wrench[:3]) == pytest.approx(0.5) and np.linalg.norm(wrench[3:]) == pytest.approx(0.25)


@pytest.mark.parametrize(("build", "name"), [
    (lambda: make_baseline_like(FIC, effective_mass=0.0), "effective_mass"),
    (lambda: make_baseline_like(FIC, effective_inertia=0.0), "effective_inertia"),
    (lambda: make_baseline_like(FIC, damping_ratio=-1e-9), "damping_ratio"),
    (lambda: LinearImpedance(200.0, 20.0, 1.0, 1.0, max_force=(0.0, 1.0)), r"max_force\[0\]"),
    (lambda: LinearImpedance(200.0, 20.0, 1.0, 1.0, max_force=(1.0, 0.0)), r"max_force\[1\]"),
])
def test_past_each_end_the_parameter_is_refused_by_name(build, name: str) -> None:
    with pytest.raises(FicInputError, match=name):
        build()
