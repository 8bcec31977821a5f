"""The safety checks' edges, where the seeded random mutation run (fic_teleop_experiments.tools.random_mutation) found
operator flips that no other test caught: the replica's limit-violation check on a joint beyond its limit, the desired
rotation given as nested lists, and the master's network tick in velocity mode."""
from __future__ import annotations

import numpy as np
import pytest
from config_values import config_values

from fic_core.errors import FicInputError
from fic_core.limits import LimitFlag, PandaLimits, limit_violations
from fic_core.master_station import MasterParameters, MasterStation
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel

DT = 0.001


def _replica(robot: RobotModel) -> ReplicaController:
    return ReplicaController(robot, PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 30.0),
                                                  ForceProfile(20.0, 0.5, 0.5, 10.0)))


@pytest.mark.parametrize("joint, side", [(0, "lower"), (3, "upper"), (5, "lower")])
def test_a_joint_beyond_its_limit_is_a_position_violation(robot: RobotModel, joint: int, side: str) -> None:
    """Torques, rates and speeds all inside, one joint 0.01 rad beyond its limit: the tick's violation flags say
    JOINT_POSITION (as the public checker does), on the first tick and on a later one."""
    limits = PandaLimits.from_robot(robot)
    q = np.array(NOMINAL_CONFIGURATION, dtype=float)
    q[joint] = limits.lower_array[joint] - 0.01 if side == "lower" else limits.upper_array[joint] + 0.01
    qd = np.zeros(7)
    replica = _replica(robot)
    robot.update(q, qd)
    position, rotation = robot.tcp_position.copy(), robot.tcp_rotation.copy()
    for _ in range(3):
        command = replica.command(q, qd, position, rotation)
        assert command.limit_violations & LimitFlag.JOINT_POSITION
        previous = command.torque
    replica.reset(previous_torque=previous)
    command = replica.command(q, qd, position, rotation)
    assert command.limit_violations == limit_violations(previous, command.torque, q, qd, command.tcp_speed, DT,
                                                        limits)
    assert command.limit_violations & LimitFlag.JOINT_POSITION


def test_a_desired_rotation_as_nested_lists_is_checked_and_accepted(robot: RobotModel) -> None:
    """A rotation as lists (not a float64 array) goes through the general check: a rotation is accepted as it is,
    a reflection and a non-orthonormal matrix are refused."""
    replica = _replica(robot)
    robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    position, rotation = robot.tcp_position.copy(), robot.tcp_rotation.copy()
    as_lists = rotation.tolist()
    from_lists = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, as_lists)
    from_array = _replica(robot).command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation)
    np.testing.assert_allclose(from_lists.torque, from_array.torque, rtol=0, atol=1e-12)
    reflection = (rotation @ np.diag([1.0, 1.0, -1.0])).tolist()
    with pytest.raises(FicInputError, match="rotation matrix"):
        replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, reflection)
    with pytest.raises(FicInputError, match="rotation matrix"):
        replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, (1.01 * rotation).tolist())
    with pytest.raises(FicInputError, match="rotation matrix"):   # the same checks on a float64 array
        replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation @ np.diag([1.0, 1.0, -1.0]))


def test_velocity_mode_integrates_over_the_time_between_network_ticks() -> None:
    """x_d' += k_v x_M dt with dt the time since the previous network tick (the first tick: dt = 0)."""
    values = {**config_values("master.yaml"), "mode": 1, "velocity_gain": 2.0, "velocity_deadband": 0.0}
    station = MasterStation(MasterParameters.from_values(values))
    station.add_pose([0.05, 0.0, 0.0], (0, 0, 0, 1), 10.0)
    first = station.desired_offset(10.0)
    np.testing.assert_allclose(first, [0.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(station.desired_offset(10.01), [2.0 * 0.05 * 0.01, 0.0, 0.0], rtol=1e-9)
    np.testing.assert_allclose(station.desired_offset(10.03), [2.0 * 0.05 * 0.03, 0.0, 0.0], rtol=1e-9)


def test_a_change_of_exactly_one_rate_step_is_not_a_torque_rate_flag(robot: RobotModel) -> None:
    """The torque-rate box is closed: tau_d exactly one step (torque_rate * dt = 1 N m) from the last command is
    inside it. Joint 4 rests 0.1 rad inside its upper limit (nearer than the braking room, so the tick takes the
    full check, not the fast path) and joint 2 moves by exactly one step: nothing is flagged, tau_d goes out as
    it is; one step and a bit more is a TORQUE_RATE flag."""
    from fic_core.postural_optimisation import PosturalOptimisation

    limits = PandaLimits.from_robot(robot)
    optimisation = PosturalOptimisation(limits, DT)
    q = np.array(NOMINAL_CONFIGURATION, dtype=float)
    q[3] = limits.upper_array[3] - 0.1
    robot.update(q, np.zeros(7))
    bias = robot.nonlinear_effects + robot.joint_damping * robot.qd
    previous = np.round(bias * 1024.0) / 1024.0   # on a grid where adding 1 N m is exact
    for extra, expected in ((0.0, LimitFlag.NONE), (1e-6, LimitFlag.TORQUE_RATE)):
        desired = previous.copy()
        desired[1] += limits.torque_rate * DT + extra
        assert extra or desired[1] - previous[1] == limits.torque_rate * DT == 1.0
        result = optimisation.shape(desired, previous, robot.q, robot.qd, bias, robot.mass_matrix_inverse,
                                    robot.tcp_jacobian[:3])
        assert result.flags == expected
        if expected == LimitFlag.NONE:
            np.testing.assert_array_equal(result.torque, desired)


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_the_rotation_angle_rate_reads_each_axis_of_the_rate(axis: int) -> None:
    """d theta/dt = (r/theta) . (w_d - w) takes each component: an error growing about one axis stays in D
    (the rate is +0.5 rad/s, past the dead-band), the same error shrinking enters C."""
    from fic_core.rotational_attractor import RotationalAttractor

    attractor = RotationalAttractor(ForceProfile(20.0, 0.5, 0.5, 10.0), rate_deadband=0.01)
    unit = np.eye(3)[axis]
    for angle in (0.05, 0.1, 0.15, 0.2):
        attractor.moment(angle * unit, 0.5 * unit)
        assert not attractor.phase.any(), angle   # D (the phase is the angle's, given on each axis)
    attractor.moment(0.19 * unit, -0.5 * unit)
    assert attractor.phase.all()


def test_a_new_postural_optimisation_has_solved_no_qp(robot: RobotModel) -> None:
    """The counts the replica's diagnostics report (QP solves, relaxed solves, last-guard clips) start at 0 and
    count one each for a relaxed QP solve (a joint past its limit, moving further out, pushed further out) and its
    last-guard clip if it had one."""
    from fic_core.postural_optimisation import PosturalOptimisation

    limits = PandaLimits.from_robot(robot)
    optimisation = PosturalOptimisation(limits, DT)
    assert (optimisation.qp_count, optimisation.relaxed_count, optimisation.guard_clips) == (0, 0, 0)
    q = np.array(NOMINAL_CONFIGURATION)
    q[0] = limits.joint_position_upper[0] + 0.05
    qd = np.zeros(7)
    qd[0] = 2.5
    state = robot.update(q, qd)
    bias = state.nonlinear_effects + robot.joint_damping * qd
    previous = state.nonlinear_effects.copy()
    result = optimisation.shape(previous + 50.0, previous, q, qd, bias, state.mass_matrix_inverse.copy(),
                                state.tcp_jacobian[:3].copy())
    assert result.relaxed and result.solved_qp
    assert (optimisation.qp_count, optimisation.relaxed_count, optimisation.guard_clips) == \
        (1, 1, int(result.guard_clipped))
