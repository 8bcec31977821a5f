"""The replica's check of a desired rotation (fic_core/replica.py): every rotation of a random set is accepted, and
every reflected or non-orthonormal matrix of a random set is refused with one FicInputError before the tick
changes anything, on each of the check's three ways in (a float64 array, the array of another type or a nested
list, and the same float64 matrix again, which the replica does not check twice). The matrices are built here:
rotations by QR of Gaussian matrices with the signs fixed, reflections as a rotation times a reflection."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fic_core.errors import FicInputError
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel

#: The check's documented tolerance on R^T R - I, elementwise (docs/CONTROL_LAWS.md, "Replica (Eq. 7) and the
#: postural optimisation").
ORTHONORMALITY_TOLERANCE = 1e-6


def random_rotation(rng) -> np.ndarray:
    """A uniformly random rotation: Q of a Gaussian matrix's QR, columns' signs fixed, det made +1."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0.0:
        q[:, 0] = -q[:, 0]
    return q


def refused_matrices(rng, rotation: np.ndarray) -> dict[str, np.ndarray]:
    """Matrices that are not rotations, built from ``rotation``: reflections (det -1, orthonormal) and
    non-orthonormal ones well past the tolerance, including some with a zero entry (a cofactor of zero)."""
    reflection = np.diag(rng.permutation([-1.0, 1.0, 1.0]))
    scaled = rotation * (1.0 + rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-5.0, -1.0))
    perturbed = rotation + rng.normal(size=(3, 3)) * 10.0 ** rng.uniform(-4.0, -1.0)
    shear = np.eye(3)
    shear[rng.integers(3), (rng.integers(1, 3))] = rng.uniform(0.01, 0.5)
    return {"reflected": rotation @ reflection, "inverted": -rotation,
            "reflected axis-aligned": np.diag(rng.permutation([-1.0, 1.0, 1.0])),
            "permutation, odd": np.eye(3)[[[0, 2, 1], [1, 0, 2], [2, 1, 0]][rng.integers(3)]],
            "scaled": scaled, "perturbed": perturbed, "sheared": rotation @ shear,
            "singular": np.outer(rotation[:, 0], rotation[:, 1]), "zero": np.zeros((3, 3))}


@pytest.fixture(scope="module")
def replica_and_state(robot: RobotModel):
    replica = ReplicaController(robot, PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 30.0),
                                                     ForceProfile(20.0, 0.5, 0.5, 10.0)))
    state = robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    return replica, state.tcp_position.copy(), state.tcp_rotation.copy()


def _ways_in(matrix: np.ndarray) -> dict[str, object]:
    return {"float64 array": np.array(matrix, dtype=np.float64), "nested list": matrix.tolist(),
            "float32 array": matrix.astype(np.float32) if np.abs(matrix).max() < 1e30 else matrix.tolist()}


def quaternion_of(rotation: np.ndarray) -> np.ndarray:
    """[x, y, z, w] of a rotation matrix (Shepperd's method: from the largest of w^2, x^2, y^2, z^2)."""
    trace = np.trace(rotation)
    squares = np.array([1.0 + trace, 1.0 + 2.0 * rotation[0, 0] - trace, 1.0 + 2.0 * rotation[1, 1] - trace,
                        1.0 + 2.0 * rotation[2, 2] - trace]) / 4.0   # w^2, x^2, y^2, z^2
    largest = int(np.argmax(squares))
    value = math.sqrt(squares[largest])
    r = rotation
    if largest == 0:
        w, x, y, z = value, (r[2, 1] - r[1, 2]) / (4 * value), (r[0, 2] - r[2, 0]) / (4 * value), \
            (r[1, 0] - r[0, 1]) / (4 * value)
    elif largest == 1:
        x, w, y, z = value, (r[2, 1] - r[1, 2]) / (4 * value), (r[0, 1] + r[1, 0]) / (4 * value), \
            (r[0, 2] + r[2, 0]) / (4 * value)
    elif largest == 2:
        y, w, x, z = value, (r[0, 2] - r[2, 0]) / (4 * value), (r[0, 1] + r[1, 0]) / (4 * value), \
            (r[1, 2] + r[2, 1]) / (4 * value)
    else:
        z, w, x, y = value, (r[1, 0] - r[0, 1]) / (4 * value), (r[0, 2] + r[2, 0]) / (4 * value), \
            (r[1, 2] + r[2, 1]) / (4 * value)
    return np.array([x, y, z, w])


def test_every_rotation_of_a_random_set_is_accepted(replica_and_state) -> None:
    """Each as a float64 matrix, a nested list, a quaternion (x, y, z, w) array, and each twice in a row (the
    second time the replica may skip the check, not the rotation); axis-aligned ones also as integer matrices.
    The desired rotation the tick reports is that rotation, as floats."""
    replica, position, _ = replica_and_state
    rng = np.random.default_rng(4403)
    rotations = [random_rotation(rng) for _ in range(150)]
    # And the axis-aligned ones, whose many zero entries make zero cofactors.
    axis_aligned = [np.eye(3), np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, -1.0, 1.0]), np.eye(3)[[1, 2, 0]],
                    np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])]
    for number, rotation in enumerate(rotations + axis_aligned):
        assert abs(np.linalg.det(rotation) - 1.0) < 1e-12
        ways = _ways_in(rotation)
        del ways["float32 array"]   # a float32 rotation's R^T R - I is ~1e-7: inside the tolerance, checked below
        ways["quaternion array"] = quaternion_of(rotation)
        if number >= len(rotations):
            ways["integer array"] = rotation.astype(np.int64)
        for way, value in ways.items():
            for _ in range(2):
                command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, value)
                assert command.desired_rotation.dtype == np.float64 and command.desired_rotation.shape == (3, 3)
                np.testing.assert_allclose(command.desired_rotation, rotation, atol=1e-12,
                                           err_msg=f"{number} {way}")


def test_every_reflected_or_non_orthonormal_matrix_of_a_random_set_is_refused(replica_and_state) -> None:
    replica, position, rotation = replica_and_state
    rng = np.random.default_rng(4404)
    refused = 0
    for number in range(80):
        for kind, matrix in refused_matrices(rng, random_rotation(rng)).items():
            for way, value in _ways_in(matrix).items():
                # After a valid rotation (the replica then skips the check for that same matrix only).
                replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation)
                ticks = replica.ticks
                with pytest.raises(FicInputError, match="desired_rotation"):
                    replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, value)
                assert replica.ticks == ticks, (number, kind, way)
                refused += 1
    assert refused == 80 * 9 * 3


@pytest.mark.parametrize("way", ["float64 array", "nested list"])
def test_the_orthonormality_tolerance_is_where_it_is_documented(replica_and_state, way: str) -> None:
    """R (1 + s) has R^T R - I = (2 s + s^2) I: accepted at s = 4e-7 (8e-7 of deviation), refused at s = 6e-7
    (1.2e-6); a reflection is refused however orthonormal it is."""
    replica, position, _ = replica_and_state
    rng = np.random.default_rng(4405)
    for _ in range(20):
        rotation = random_rotation(rng)
        replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position,
                        _ways_in(rotation * (1.0 + 4e-7))[way])
        assert 2 * 6e-7 > ORTHONORMALITY_TOLERANCE > 2 * 4e-7 + 1.6e-13
        with pytest.raises(FicInputError, match="desired_rotation"):
            replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, _ways_in(rotation * (1.0 + 6e-7))[way])
        with pytest.raises(FicInputError, match="desired_rotation"):
            replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position,
                            _ways_in(rotation @ np.diag([1.0, 1.0, -1.0]))[way])


@pytest.mark.parametrize("way", ["float64 array", "nested list"])
def test_a_deviation_exactly_at_the_tolerance_is_accepted_and_one_just_past_it_refused(replica_and_state,
                                                                                       way: str) -> None:
    """[[1, t, 0], [0, 1, 0], [0, 0, 1]] has (R^T R - I)_01 = t exactly (1 x t, in floats too), its other
    entries below it, and det 1: accepted at t = the tolerance, refused at the next float above it."""
    replica, position, _ = replica_and_state
    for tolerance, accepted in ((ORTHONORMALITY_TOLERANCE, True), (np.nextafter(ORTHONORMALITY_TOLERANCE, 1.0), False)):
        matrix = np.eye(3)
        matrix[0, 1] = tolerance
        assert np.abs(matrix.T @ matrix - np.eye(3)).max() == tolerance
        value = _ways_in(matrix)[way]
        if accepted:
            replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, value)
        else:
            with pytest.raises(FicInputError, match="desired_rotation"):
                replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, value)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_non_finite_entry_anywhere_is_refused_as_not_finite(replica_and_state, bad: float) -> None:
    replica, position, rotation = replica_and_state
    for row in range(3):
        for column in range(3):
            matrix = rotation.copy()
            matrix[row, column] = bad
            for value in (matrix, matrix.tolist()):
                with pytest.raises(FicInputError, match="desired_rotation must be finite"):
                    replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, value)


@pytest.mark.parametrize("shape", [(4, 3), (3, 4), (2, 3), (9,), (3,), (4, 4)])
def test_a_float64_array_of_another_shape_is_refused_in_one_line(replica_and_state, shape) -> None:
    replica, position, _ = replica_and_state
    value = np.zeros(shape)
    value.flat[::4] = 1.0
    for _ in range(2):
        with pytest.raises(FicInputError, match="desired_rotation"):
            replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, value)
