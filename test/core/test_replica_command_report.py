"""What a replica command reports about its own tick (ReplicaCommand): a quiet tick says it was not shaped, not
solved, not relaxed and not clipped; the torque-rate ratio is |tau - tau_prev| / (rate limit x the interval since
the last command), 1 for a command the slew stopped at the rate limit at any interval; and reading the report does
not change what the command shows of itself (its report cache is no field of it)."""
from __future__ import annotations

import numpy as np
import pytest
from test_replica_handover import paper_fic, rest  # the paper's replica FIC, and the arm at rest

from fic_core.limits import LimitFlag
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel


def test_a_quiet_tick_reports_no_shaping_no_qp_no_relaxation_and_no_clip(robot: RobotModel) -> None:
    replica = ReplicaController(robot, paper_fic(), control_period=0.001)
    position, rotation, _ = rest(robot)
    for _ in range(3):
        command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation)
        assert (command.limit_shaping, command.limit_violations) == (LimitFlag.NONE, LimitFlag.NONE)
        assert (command.solved_qp, command.relaxed, command.guard_clipped) == (False, False, False)
        assert command.torque_change == 0.0
        np.testing.assert_array_equal(command.torque, command.unshaped_torque)
    assert replica.optimisation.guard_clips == 0


@pytest.mark.parametrize(("period", "gap"), [(0.004, 0.004), (0.002, 0.002), (0.004, 0.002), (0.001, 0.003)])
def test_the_torque_rate_ratio_is_the_change_over_the_rate_limit_times_the_interval(
        robot: RobotModel, period: float, gap: float) -> None:
    """A 10 cm step of x_d: the law moves one rate step of its period (the optimisation's box) on the joints it
    stops, sent over the interval since the last command (at least one command period; torque_slew.py): the ratio
    is period / interval there, 1 when the command comes a period after the last, 1/3 three periods after."""
    replica = ReplicaController(robot, paper_fic(), control_period=period, command_period=period)
    position, rotation, gravity = rest(robot)
    replica.reset(previous_torque=gravity)
    first = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation, time=0.0)
    command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position + [0.1, 0.0, 0.0], rotation, time=gap)
    interval = max(period, gap)
    assert command.interval == pytest.approx(interval, rel=1e-12)
    rate = replica.limits.torque_rate
    change = np.abs(command.torque - first.torque)
    assert change.max() == pytest.approx(rate * period, rel=1e-9)
    np.testing.assert_allclose(command.torque_rate_ratio, change / (rate * interval), rtol=1e-9)
    assert command.torque_rate_ratio.max() == pytest.approx(period / interval, rel=1e-9)


def test_reading_the_report_leaves_the_commands_repr_as_it_was(robot: RobotModel) -> None:
    replica = ReplicaController(robot, paper_fic(), control_period=0.001)
    position, rotation, _ = rest(robot)
    command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position + [0.01, 0.0, 0.0], rotation)
    before = repr(command)
    _ = command.stored_energy, command.kinetic_energy, command.torque_ratio, command.posture_torque
    assert repr(command) == before
    assert "_cache" not in before


def test_the_total_energy_is_the_springs_storage_plus_the_arms_kinetic_energy(robot: RobotModel) -> None:
    replica = ReplicaController(robot, paper_fic(), control_period=0.001)
    position, rotation, _ = rest(robot)
    qd = np.full(7, 0.2)
    command = replica.command(NOMINAL_CONFIGURATION, qd, position + [0.02, 0.0, 0.0], rotation)
    stored = float(command.stored_energy.sum())
    assert stored > 0.0 and command.kinetic_energy > 0.0
    robot.update(NOMINAL_CONFIGURATION, qd)
    assert command.kinetic_energy == pytest.approx(0.5 * qd @ robot.mass_matrix @ qd, rel=1e-9)
    assert command.total_energy == pytest.approx(stored + command.kinetic_energy, rel=1e-12)
