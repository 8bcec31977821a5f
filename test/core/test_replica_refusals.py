"""The replica refuses what it cannot command from, in one line naming it, and commits nothing then: a task
controller's non-finite or mis-shaped wrench, a desired rotation that stops being one after a valid one (the tick
checks a matrix equal to the last valid one only once), and construction values outside their ranges."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.errors import FicInputError
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel


def paper_fic() -> PoseAttractor:
    """The paper's replica FIC (Sec. III): K0 = 200 N/m, x_b = 0.05 m; rotation 20 N m/rad, x_b = 0.5 rad."""
    return PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 30.0), ForceProfile(20.0, 0.5, 0.5, 10.0))


class ProtocolOnly:
    """A task controller with only the protocol's ``wrench`` (no ``wrench_values``), returning what it is told."""

    controller_name = "test"

    def __init__(self, wrench) -> None:
        self._wrench = wrench
        self.phase = np.zeros(6, dtype=np.int64)
        self.latched_max_error = np.zeros(6)
        self.last_force = np.zeros(6)
        self.stored_energy = np.zeros(6)

    def wrench(self, position_error, rotation_error, twist_error):
        return self._wrench

    def reset(self) -> None:
        pass


def rest_pose(robot: RobotModel) -> tuple[np.ndarray, np.ndarray]:
    robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    return robot.tcp_position.copy(), robot.tcp_rotation.copy()


@pytest.mark.parametrize(("wrench", "message"), [
    (np.array([0.0, np.nan, 0.0, 0.0, 0.0, 0.0]), "non-finite wrench"),
    (np.array([np.inf, 0.0, 0.0, 0.0, 0.0, 0.0]), "non-finite wrench"),
    (np.zeros(3), "mis-shaped wrench"),
    (np.zeros((6, 1)), "mis-shaped wrench"),
])
def test_a_controllers_unusable_wrench_is_refused_and_nothing_is_sent(robot: RobotModel, wrench,
                                                                       message: str) -> None:
    position, rotation = rest_pose(robot)
    replica = ReplicaController(robot, ProtocolOnly(wrench))
    with np.errstate(invalid="ignore"), pytest.raises(FicInputError, match=message):   # (inf * 0 in J^T F)
        replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation)
    assert replica.ticks == 0 and replica.previous_torque is None and replica.held_torque() is None
    # The same replica commands again once the controller's wrench is usable (a zero wrench: gravity and posture).
    replica.controller = ProtocolOnly(np.zeros(6))
    command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation)
    assert replica.ticks == 1 and np.isfinite(command.torque).all()


def test_a_valid_rotation_checked_once_does_not_let_a_later_invalid_one_through(robot: RobotModel) -> None:
    """The tick skips the orthonormality test for a matrix equal to the last one that passed it; any other matrix
    is tested: scaled, reflected, NaN (which never equals anything) are refused after the valid one, each without
    a tick, and the valid one passes again."""
    position, rotation = rest_pose(robot)
    replica = ReplicaController(robot, paper_fic())
    replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation)
    nan = rotation.copy()
    nan[1, 1] = np.nan
    tilted = rotation.copy()
    tilted[0, 0] += 2e-6     # past the 1e-6 orthonormality tolerance
    for bad in (1.1 * rotation, -rotation, nan, tilted, rotation.T @ np.diag([1.0, 1.0, -1.0])):
        with pytest.raises(FicInputError, match="desired_rotation"):
            replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, bad)
        assert replica.ticks == 1
    replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation.copy())
    assert replica.ticks == 2
    # Within the tolerance it is a rotation.
    nudged = rotation.copy()
    nudged[0, 0] += 2e-7
    replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, nudged)
    assert replica.ticks == 3


@pytest.mark.parametrize(("keyword", "value", "name"), [
    ("feedforward_regularisation", 0.0, "feedforward_regularisation"),
    ("feedforward_regularisation", -1e-3, "feedforward_regularisation"),
    ("feedforward_limit", (-1.0, 10.0), r"feedforward_limit\[0\]"),
    ("feedforward_limit", (30.0, np.nan), r"feedforward_limit\[1\]"),
    ("control_period", 0.0, "control_period"),
    ("control_period", np.inf, "control_period"),
])
def test_construction_values_out_of_range_are_refused_by_name(robot: RobotModel, keyword: str, value,
                                                               name: str) -> None:
    with pytest.raises(FicInputError, match=name):
        ReplicaController(robot, paper_fic(), **{keyword: value})


def test_a_zero_feedforward_limit_removes_the_feedforward(robot: RobotModel) -> None:
    """Bounds of 0 N and 0 N m (the least allowed) leave no feedforward wrench, whatever the acceleration asked."""
    position, rotation = rest_pose(robot)
    bounded = ReplicaController(robot, paper_fic(), feedforward_limit=(0.0, 0.0))
    command = bounded.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation,
                              desired_acceleration=[5.0, -3.0, 2.0, 1.0, 1.0, 1.0])
    np.testing.assert_array_equal(command.feedforward_wrench, np.zeros(6))
    plain = ReplicaController(robot, paper_fic()).command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation)
    np.testing.assert_allclose(command.unshaped_torque, plain.unshaped_torque, rtol=0.0, atol=1e-9)
