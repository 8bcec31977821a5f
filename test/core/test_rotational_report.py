"""What the FIC on the rotation angle reports (rotational_attractor.py's docstring): the phase on all three
rotational slots, the moment M = FIC(theta) r/theta as the force, and the angle's scalar quantities (theta, e_max,
V) in the first slot with zeros in the other two; the phase chosen by d theta/dt = (r/theta) . (w_d - w) alone.
Every expected value is written out here from Eqs. 1 and 2 (the profile's F_c and its integral V_D)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_core.attractor import FractalAttractor
from fic_core.errors import FicInputError
from fic_core.profile import ForceProfile
from fic_core.rotational_attractor import RotationalAttractor

#: The replica's rotation FIC (config/replica.yaml): K0 20 N m/rad, x_b 0.5 rad, xi 0.5, F_max 10 N m.
PROFILE = ForceProfile(20.0, 0.5, 0.5, 10.0)
ERROR = np.array([0.3, 0.4, 0.0])      # theta = 0.5 rad, on the profile's linear end (xi x_b = 0.25) and past it
AXIS = ERROR / 0.5
RELATIVE = 1e-12


def test_at_rest_nothing_is_reported_and_the_parts_are_named() -> None:
    attractor = RotationalAttractor(PROFILE)
    assert attractor.profile is PROFILE and attractor.axes == 3
    assert attractor.rate_deadband == 0.005
    assert isinstance(attractor.angle_attractor, FractalAttractor) and attractor.angle_attractor.axes == 1
    for values in (attractor.phase, attractor.latched_max_error, attractor.last_force, attractor.stored_energy):
        np.testing.assert_array_equal(values, np.zeros(3))
    assert attractor.snapshot().angle == 0.0
    with pytest.raises(FicInputError, match="ForceProfile"):
        RotationalAttractor((20.0, 0.5, 0.5, 10.0))


def test_in_divergence_the_angles_port_is_in_the_first_slot() -> None:
    """Diverging (theta growing): M = F_c(theta) u, and the port (theta, F_c(theta), V_D(theta)) in slot one."""
    attractor = RotationalAttractor(PROFILE)
    moment = attractor.moment(ERROR, 1.0 * AXIS)
    force = PROFILE.scalar_force(0.5)
    np.testing.assert_allclose(moment, force * AXIS, rtol=RELATIVE)
    snapshot = attractor.snapshot()
    assert snapshot.angle == pytest.approx(0.5, rel=RELATIVE)
    assert snapshot.errors == (snapshot.angle, 0.0, 0.0)
    np.testing.assert_array_equal(snapshot.forces, moment)
    np.testing.assert_array_equal(attractor.last_force, moment)
    errors, forces, storages = snapshot.port_values()
    assert errors == (snapshot.angle, 0.0, 0.0)
    assert forces[0] == pytest.approx(force, rel=RELATIVE) and forces[1:] == (0.0, 0.0)
    assert storages[0] == pytest.approx(PROFILE.scalar_energy(0.5), rel=1e-9) and storages[1:] == [0.0, 0.0]
    np.testing.assert_array_equal(attractor.stored_energy, storages)
    np.testing.assert_array_equal(attractor.phase, [0, 0, 0])
    np.testing.assert_array_equal(attractor.latched_max_error, [0.0, 0.0, 0.0])


def test_in_convergence_every_slot_says_c_and_e_max_is_in_the_first() -> None:
    """Then theta falls (0.5 -> 0.45 rad, d theta/dt = -1 rad/s, past the dead-band): C on all three slots,
    e_max = 0.5 latched in slot one, and M = K_C (theta - e_max/2) u with Eq. 2's K_C = 2 F_c(e_max)/e_max, capped
    at 8 V_D(e_max)/e_max^2 (attractor.py)."""
    attractor = RotationalAttractor(PROFILE)
    attractor.moment(ERROR, 1.0 * AXIS)
    moment = attractor.moment(0.9 * ERROR, -1.0 * AXIS)
    stiffness = min(2.0 * PROFILE.scalar_force(0.5) / 0.5, 8.0 * PROFILE.scalar_energy(0.5) / 0.25)
    np.testing.assert_allclose(moment, stiffness * (0.45 - 0.25) * AXIS, rtol=1e-9)
    np.testing.assert_array_equal(attractor.phase, [1, 1, 1])
    assert attractor.snapshot().in_convergence == (True, True, True)
    latched = attractor.latched_max_error
    assert latched[0] == pytest.approx(0.5, rel=RELATIVE) and latched[1:].tolist() == [0.0, 0.0]
    storages = attractor.stored_energy
    assert storages[0] > 0.0 and storages[1:].tolist() == [0.0, 0.0]


def test_only_the_rate_along_the_axis_chooses_the_phase() -> None:
    """A rate across the axis does not change theta (d theta/dt = 0): the axis stays in D however fast; a rate
    along it, falling just past the 0.005 rad/s dead-band, enters C; just inside it does not."""
    across = np.cross(AXIS, [0.0, 0.0, 1.0])
    assert abs(across @ AXIS) < 1e-15
    for rate, converging in ((-10.0 * across, 0), (-0.0051 * AXIS, 1), (-0.0049 * AXIS, 0),
                             (-0.0051 * AXIS + 10.0 * across, 1)):
        attractor = RotationalAttractor(PROFILE)
        attractor.moment(ERROR, AXIS)
        moment = attractor.moment(0.999 * ERROR, rate)
        np.testing.assert_array_equal(attractor.phase, [converging] * 3)
        if not converging:
            np.testing.assert_allclose(moment, PROFILE.scalar_force(0.4995) * AXIS, rtol=1e-9)


def test_below_the_resolvable_angle_the_moment_and_the_angle_are_zero() -> None:
    """theta under 1e-12 rad: no axis, no moment, the angle reads 0 (the profile's force there is < K0 1e-12)."""
    attractor = RotationalAttractor(PROFILE)
    attractor.moment(ERROR, AXIS)
    tiny = np.array([3e-13, -4e-13, 0.0])
    assert math.isclose(np.linalg.norm(tiny), 5e-13)
    np.testing.assert_array_equal(attractor.moment(tiny, -AXIS), np.zeros(3))
    snapshot = attractor.snapshot()
    assert snapshot.angle == 0.0 and snapshot.errors == (0.0, 0.0, 0.0)
    assert snapshot.moment == (0.0, 0.0, 0.0)
    # Just above it the axis is resolved: the linear region's K0 theta along it.
    small = np.array([3e-11, -4e-11, 0.0])
    np.testing.assert_allclose(RotationalAttractor(PROFILE).moment(small, np.zeros(3)), 20.0 * small, rtol=1e-9)
