"""Homing (fic_core.handle_homing): the handle is brought to the centre no faster than homing_speed, without
overshooting the tolerance, and the attractor is a plain spring-damper where its speed bound does not act."""
from __future__ import annotations

import numpy as np
import pytest
from config_values import config_values

from fic_core.errors import FicInputError
from fic_core.handle_homing import HandleHoming

MASTER = config_values("master.yaml")
MASS, DEVICE_DAMPING = 0.5, 2.0   # the simulated handle (config/haptic_device.yaml)


def shipped() -> HandleHoming:
    return HandleHoming(MASTER["homing_stiffness"], MASTER["homing_damping"], MASTER["homing_speed"],
                        MASTER["homing_tolerance"])


def home(homing: HandleHoming, start, seconds: float = 6.0, control_period: float = 0.004):
    """A free handle (mass and the mechanism's damping) at 1 kHz under the force held over each control period;
    the positions and speeds of every step, and the time it was first homed (None if never)."""
    position, velocity, force = np.array(start, dtype=float), np.zeros(3), np.zeros(3)
    positions, speeds, homed_at = [], [], None
    every = round(control_period / 0.001)
    for k in range(round(seconds / 0.001)):
        if k % every == 0:
            force = homing.force(position, velocity)
            if homed_at is None and homing.homed(position):
                homed_at = k * 0.001
        velocity = velocity + 0.001 * (force - DEVICE_DAMPING * velocity) / MASS
        position = position + 0.001 * velocity
        positions.append(position.copy())
        speeds.append(float(np.linalg.norm(velocity)))
    return np.array(positions), np.array(speeds), homed_at


def test_the_speed_toward_the_centre_is_bounded() -> None:
    homing = shipped()
    start = [0.08, -0.04, 0.03]
    positions, speeds, homed_at = home(homing, start)
    assert speeds.max() <= homing.speed
    # Most of the way at (nearly) the bound: the 0.099 m take 2-3 s at 0.05 m/s, then the approach slows.
    distance = float(np.linalg.norm(start))
    assert homed_at is not None and distance / homing.speed < homed_at < distance / homing.speed + 1.0
    assert speeds[: round(0.5 * homed_at / 0.001)].max() > 0.75 * homing.speed
    # It comes in along the line to the centre and does not overshoot it by more than the tolerance.
    direction = -np.array(start) / distance
    assert np.min(positions @ -direction) > -homing.tolerance
    assert np.linalg.norm(positions[-1]) < homing.tolerance


def test_without_the_bound_the_same_spring_flings_the_handle() -> None:
    """The bound is what keeps the speed down: the same spring-damper unbounded (a speed bound far off) reaches
    several times homing_speed from the same start."""
    bounded, unbounded = shipped(), HandleHoming(MASTER["homing_stiffness"], MASTER["homing_damping"], 10.0,
                                                 MASTER["homing_tolerance"])
    start = [0.08, -0.04, 0.03]
    assert home(unbounded, start)[1].max() > 3.0 * home(bounded, start)[1].max()


def test_near_the_centre_it_is_a_spring_damper_and_far_out_a_damper_toward_the_bound() -> None:
    homing = shipped()
    x, v = np.array([0.001, -0.0005, 0.0]), np.array([0.01, 0.0, -0.002])
    np.testing.assert_allclose(homing.force(x, v), -homing.stiffness * x - homing.damping * v)
    far = np.array([0.09, 0.0, 0.0])
    np.testing.assert_allclose(homing.force(far, np.zeros(3)), [-homing.damping * homing.speed, 0.0, 0.0])
    assert homing.homed(np.array([homing.tolerance, 0.0, 0.0])) and not homing.homed(far)


@pytest.mark.parametrize("name", ["stiffness", "damping", "speed", "tolerance"])
def test_a_gain_that_is_not_positive_is_refused(name: str) -> None:
    values = {"stiffness": 40.0, "damping": 10.0, "speed": 0.05, "tolerance": 0.002, name: 0.0}
    with pytest.raises(FicInputError, match=f"homing_{name}"):
        HandleHoming(**values)
