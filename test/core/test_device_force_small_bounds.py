"""Any positive device-force bound is a bound (the master's `max_device_force` row: 0 is "no limit", every other
value in its range bounds the command's norm, docs/INTERFACES.md): a bound below a newton, given at construction,
set live on the law or through the station, caps the force at exactly its value, in the force's direction."""
from __future__ import annotations

import numpy as np
from config_values import config_values

from fic_core.attractor import FractalAttractor
from fic_core.master import MasterLaw
from fic_core.master_station import MasterParameters, MasterStation
from fic_core.profile import ForceProfile

PROFILE = ForceProfile(stiffness=200.0, saturation_error=0.03, saturation_start=0.5, max_force=8.0)
REPLICA_FORCE = np.array([3.0, -4.0, 0.0])   # 5 N; the handle at the centre and at rest: f = K_H F_R


def _capped(master: MasterLaw, bound: float) -> None:
    force = master.force(np.zeros(3), np.zeros(3), REPLICA_FORCE)
    assert np.isclose(np.linalg.norm(force), bound, rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(force / np.linalg.norm(force), [0.6, -0.8, 0.0], rtol=1e-12)
    assert master.device_force_saturated


def test_a_bound_below_a_newton_caps_the_force_at_construction_and_set_live() -> None:
    for bound in (0.5, 1e-3):
        _capped(MasterLaw(FractalAttractor(PROFILE, 3, rate_deadband=0.005), 1.0, bound), bound)
        master = MasterLaw(FractalAttractor(PROFILE, 3, rate_deadband=0.005), 1.0, 20.0)
        master.max_device_force = bound
        assert master.max_device_force == bound
        _capped(master, bound)


def test_the_station_takes_a_bound_below_a_newton_at_start_and_live() -> None:
    values = config_values("master.yaml")
    started = MasterStation(MasterParameters.from_values({**values, "max_device_force": 0.25}))
    assert started.law.max_device_force == 0.25
    live = MasterStation(MasterParameters.from_values(values))
    live.configure({"max_device_force": 0.75})
    assert live.law.max_device_force == 0.75
    live.configure({"max_device_force": 0.0})
    assert live.law.max_device_force is None
