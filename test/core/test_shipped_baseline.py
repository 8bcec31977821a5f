"""The linear baseline's defaults are the shipped one: config/replica.yaml writes the dampings the replica node uses
for ``controller: linear`` (39.6 N s/m and 1.98 N m s/rad, docs/CONTROL_LAWS.md's E4 baseline: damping ratio 0.7 on
a 4 kg effective mass and 0.1 kg m^2), and ``make_baseline_like`` with its defaults on the shipped stiffnesses must
give those, so that an in-process baseline built without arguments is the one the graph runs."""
from __future__ import annotations

import math

import numpy as np
import pytest
from config_values import config_values

from fic_core.baseline import make_baseline_like
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile


def shipped_pose_attractor(values: dict) -> PoseAttractor:
    def profile(prefix: str) -> ForceProfile:
        return ForceProfile(values[f"{prefix}_stiffness"], values[f"{prefix}_saturation_error"],
                            values[f"{prefix}_saturation_start"], values[f"{prefix}_max_force"])
    return PoseAttractor(profile("translation"), profile("rotation"))


def test_the_default_baseline_has_the_shipped_dampings() -> None:
    values = config_values("replica.yaml")
    baseline = make_baseline_like(shipped_pose_attractor(values))
    np.testing.assert_array_equal(baseline.stiffness, [values["translation_stiffness"]] * 3
                                  + [values["rotation_stiffness"]] * 3)
    # config/replica.yaml writes them to three figures.
    assert baseline.damping[:3] == pytest.approx([values["linear_translation_damping"]] * 3, abs=0.05)
    assert baseline.damping[3:] == pytest.approx([values["linear_rotation_damping"]] * 3, abs=0.005)
    assert (values["linear_translation_damping"], values["linear_rotation_damping"]) == (39.6, 1.98)


def test_the_default_damping_ratio_is_0_7_on_each_block() -> None:
    """zeta = D / (2 sqrt(K m)) with the effective mass and inertia the shipped dampings were computed for."""
    values = config_values("replica.yaml")
    baseline = make_baseline_like(shipped_pose_attractor(values))
    for damping, stiffness, mass in ((baseline.damping[0], values["translation_stiffness"], 4.0),
                                     (baseline.damping[3], values["rotation_stiffness"], 0.1)):
        assert damping / (2.0 * math.sqrt(stiffness * mass)) == pytest.approx(0.7, rel=1e-12)
