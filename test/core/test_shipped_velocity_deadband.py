"""The velocity mode's dead-band by default is the shipped one (config/master.yaml: a resting hand within 5 mm of
the origin does not drift x_d'), and outside it x_d' moves at k_v (|x_M| - 5 mm) along x_M (teleoperation.py)."""
from __future__ import annotations

import numpy as np
import pytest
from config_values import config_values

from fic_core.teleoperation import TeleoperationCommandIntegrator, TeleoperationMode


def test_the_default_dead_band_is_the_shipped_5_mm() -> None:
    shipped = config_values("master.yaml")["velocity_deadband"]
    assert shipped == 0.005
    integrator = TeleoperationCommandIntegrator(velocity_gain=2.0, mode=TeleoperationMode.VELOCITY)
    assert integrator.velocity_deadband == shipped
    start = integrator.update([0.0, 0.0, 0.0], 0.01).copy()
    for _ in range(100):   # a hand resting 4.9 mm out for a second
        integrator.update([0.0049, 0.0, 0.0], 0.01)
    np.testing.assert_array_equal(integrator.desired_offset, start)
    integrator.update([0.015, 0.0, 0.0], 0.01)   # 10 mm past the dead-band: k_v x 10 mm x 10 ms
    assert integrator.desired_offset[0] - start[0] == pytest.approx(2.0 * 0.010 * 0.01, rel=1e-9)
