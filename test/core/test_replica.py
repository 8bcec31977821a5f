"""ReplicaController: paper Eq. 7 + postural optimisation, on the real PoseAttractor and LinearImpedance.

The closed loops (convergence, the circle with feedforward and friction compensation) run on the MuJoCo arm:
test/sim/test_replica_on_mujoco.py; Eq. 7 and the QP against independent oracles: test_oracles.py.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

from fic_core.baseline import LinearImpedance
from fic_core.errors import FicInputError
from fic_core.limits import LimitFlag, PandaLimits, limit_violations
from fic_core.panda_description import JOINT_DAMPING, NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.quaternion import rotation_from_quaternion
from fic_core.replica import ReplicaCommand, ReplicaController
from fic_core.robot_model import RobotModel

DT = 0.001


def paper_fic() -> PoseAttractor:
    """The paper's replica FIC: K0 = 200 N/m, x_b = 0.05 m (Sec. III); rotation 20 N m/rad, x_b = 0.5 rad."""
    return PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 30.0), ForceProfile(20.0, 0.5, 0.5, 10.0))


def nominal_pose(robot: RobotModel) -> tuple[np.ndarray, np.ndarray]:
    robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    return robot.tcp_position.copy(), robot.tcp_rotation.copy()


def test_posture_term_lies_in_the_dynamically_consistent_null_space(robot: RobotModel) -> None:
    """J M^-1 tau_posture = 0 (M from Pinocchio in the test); Eq. 7's sum itself: test_oracles.py."""
    replica = ReplicaController(robot, paper_fic())
    rng = np.random.default_rng(21)
    data = robot.model.createData()
    position, rotation = nominal_pose(robot)
    for _ in range(20):
        q = NOMINAL_CONFIGURATION + rng.normal(scale=0.2, size=7)
        qd = rng.normal(scale=0.3, size=7)
        command = replica.command(q, qd, position + rng.normal(scale=0.02, size=3), rotation)
        jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.tcp_frame_id, pin.LOCAL_WORLD_ALIGNED)
        minv = pin.computeMinverse(robot.model, data, q)
        minv = np.triu(minv) + np.triu(minv, 1).T
        assert np.linalg.norm(jacobian @ minv @ command.posture_torque) < 1e-6 * max(
            1.0, np.linalg.norm(minv @ command.posture_torque))
        assert np.linalg.norm(command.posture_torque) > 0.0


def test_quiet_tick_is_unshaped(robot: RobotModel) -> None:
    replica = ReplicaController(robot, paper_fic())
    position, rotation = nominal_pose(robot)
    replica.reset(previous_torque=robot.nonlinear_effects)
    command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position + [0.001, 0.0, 0.0], rotation)
    assert command.limit_shaping == LimitFlag.NONE
    assert command.limit_violations == LimitFlag.NONE
    assert not command.solved_qp
    np.testing.assert_array_equal(command.torque, command.unshaped_torque)
    assert command.torque_change == 0.0


def test_huge_demand_is_flagged_and_kept_inside(robot: RobotModel, limits: PandaLimits) -> None:
    stiff = LinearImpedance(1e6, 1e5, 0.0, 0.0)
    replica = ReplicaController(robot, stiff)
    position, rotation = nominal_pose(robot)
    replica.reset(previous_torque=robot.nonlinear_effects)
    command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position + [0.3, 0.0, 0.0], rotation)
    assert command.limit_shaping & LimitFlag.TORQUE_RATE
    assert command.limit_violations == LimitFlag.NONE
    assert np.all(np.abs(command.torque - command.previous_torque) <= 1.0 + 1e-9)
    assert np.max(command.torque_rate_ratio) == pytest.approx(1.0)
    assert replica.shaped_ticks == 1 and replica.ticks == 1 and replica.violation_ticks == 0


def random_pose_near(rng, position, rotation):
    axis = rng.normal(size=3)
    angle = rng.uniform(0.0, 2.0)
    return position + rng.normal(scale=0.5, size=3), pin.exp3(axis / np.linalg.norm(axis) * angle) @ rotation


def test_random_states_never_break_torque_or_rate(robot: RobotModel, limits: PandaLimits) -> None:
    """Thousands of random states (incl. at and near the joint limits, speeds up to 110 % of the limits) with
    huge wrench demands and random previous torques: the command never breaks the torque and torque-rate limits,
    the shaping flags are set exactly when the command differs from tau_d."""
    rng = np.random.default_rng(22)
    position, rotation = nominal_pose(robot)
    lower, upper, v_max = limits.lower_array, limits.upper_array, limits.joint_velocity_array
    shaped = 0
    for controller in (LinearImpedance(1e5, 1e4, 1e3, 1e2),
                       PoseAttractor(ForceProfile(1e4, 0.05, 0.5, 5e3), ForceProfile(1e3, 0.5, 0.5, 500.0))):
        replica = ReplicaController(robot, controller)
        for _ in range(1000):
            near = rng.random(7) < 0.2
            edge = np.where(rng.random(7) < 0.5, lower + rng.uniform(0, 0.05, 7), upper - rng.uniform(0, 0.05, 7))
            q = np.where(near, edge, rng.uniform(lower, upper))
            qd = rng.uniform(-1.1, 1.1, 7) * v_max
            previous = rng.uniform(-1, 1, 7) * limits.torque_array
            replica.reset(previous_torque=previous)
            desired_position, desired_rotation = random_pose_near(rng, position, rotation)
            command = replica.command(q, qd, desired_position, desired_rotation, rng.normal(size=6))
            torque = command.torque
            assert np.all(np.isfinite(torque))
            assert np.all(np.abs(torque) <= limits.torque_array + 1e-9)
            assert np.all(np.abs(torque - previous) <= limits.torque_rate * DT + 1e-9)
            assert not command.limit_violations & (LimitFlag.TORQUE | LimitFlag.TORQUE_RATE)
            if command.limit_shaping == LimitFlag.NONE:
                np.testing.assert_array_equal(torque, command.unshaped_torque)
            else:
                shaped += 1
                assert command.torque_change > 0.0
            # The measured-state flags agree with the public checker.
            assert command.limit_violations == limit_violations(previous, torque, q, qd, command.tcp_speed, DT,
                                                                limits)
    assert shaped > 1500


def test_hold_keeps_the_current_pose_before_any_command(robot: RobotModel) -> None:
    replica = ReplicaController(robot, paper_fic())
    position, rotation = nominal_pose(robot)
    command = replica.hold(NOMINAL_CONFIGURATION, np.zeros(7))
    np.testing.assert_allclose(command.desired_position, position)
    np.testing.assert_allclose(command.desired_rotation, rotation)
    np.testing.assert_allclose(command.tracking_error, 0.0, atol=1e-12)
    target = position + [0.01, 0.0, 0.0]
    replica.command(NOMINAL_CONFIGURATION, np.zeros(7), target, rotation)
    np.testing.assert_allclose(replica.hold(NOMINAL_CONFIGURATION, np.zeros(7)).desired_position, target)


def test_quaternion_and_matrix_give_the_same_command(robot: RobotModel) -> None:
    position, rotation = nominal_pose(robot)
    quaternion = pin.Quaternion(rotation)  # coefficients in (x, y, z, w) order, as ROS
    np.testing.assert_allclose(rotation_from_quaternion(quaternion.coeffs()), rotation, atol=1e-12)
    first = ReplicaController(robot, paper_fic()).command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation)
    second = ReplicaController(robot, paper_fic()).command(NOMINAL_CONFIGURATION, np.zeros(7), position,
                                                           2.0 * quaternion.coeffs())
    np.testing.assert_allclose(first.torque, second.torque, atol=1e-9)


@pytest.mark.parametrize("argument", ["q", "qd", "position", "rotation", "twist"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_inputs_are_rejected(robot: RobotModel, argument: str, bad: float) -> None:
    replica = ReplicaController(robot, paper_fic())
    position, rotation = nominal_pose(robot)
    arguments = {"q": NOMINAL_CONFIGURATION.copy(), "qd": np.zeros(7), "position": position.copy(),
                 "rotation": rotation.copy(), "twist": np.zeros(6)}
    arguments[argument].flat[1] = bad
    with pytest.raises(FicInputError):
        replica.command(arguments["q"], arguments["qd"], arguments["position"], arguments["rotation"],
                        arguments["twist"])
    assert replica.ticks == 0 and replica.previous_torque is None  # nothing was committed


def test_invalid_rotations_are_rejected(robot: RobotModel) -> None:
    replica = ReplicaController(robot, paper_fic())
    position, rotation = nominal_pose(robot)
    with pytest.raises(FicInputError, match="rotation matrix"):
        replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, 1.1 * rotation)
    with pytest.raises(FicInputError, match="rotation matrix"):
        replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, -rotation)  # det -1
    with pytest.raises(FicInputError, match="norm"):
        replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, np.zeros(4))
    with pytest.raises(FicInputError, match="shape"):
        replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, np.zeros(5))


def test_the_feedforward_is_bounded_by_its_limit(robot: RobotModel) -> None:
    """With feedforward_limit (F, M), |Lambda a_d| force and moment never exceed F and M, even for a wild a_d;
    a small a_d passes unchanged."""
    rng = np.random.default_rng(11)
    position, rotation = nominal_pose(robot)
    for _ in range(10):
        q = NOMINAL_CONFIGURATION + rng.normal(scale=0.2, size=7)
        qd = rng.normal(scale=0.3, size=7)
        wild = rng.normal(scale=50.0, size=6)
        command = ReplicaController(robot, paper_fic(), feedforward_limit=(15.0, 5.0)).command(
            q, qd, position, rotation, None, wild)
        assert np.linalg.norm(command.feedforward_wrench[:3]) <= 15.0 + 1e-9
        assert np.linalg.norm(command.feedforward_wrench[3:]) <= 5.0 + 1e-9
        gentle = 0.01 * np.ones(3)
        bounded = ReplicaController(robot, paper_fic(), feedforward_limit=(15.0, 5.0)).command(
            q, qd, position, rotation, None, gentle)
        free = ReplicaController(robot, paper_fic()).command(q, qd, position, rotation, None, gentle)
        np.testing.assert_array_equal(bounded.unshaped_torque, free.unshaped_torque)


def test_joint_damping_compensation_adds_the_friction_of_the_desired_motion(robot: RobotModel) -> None:
    """The unshaped torque differs by D M^-1 J^T Lambda xd_d (independent Pinocchio calls), at random states, and
    not at all without a desired twist (the damping of deviations stays the arm's)."""
    rng = np.random.default_rng(5)
    position, rotation = nominal_pose(robot)
    data = robot.model.createData()
    for _ in range(10):
        q = NOMINAL_CONFIGURATION + rng.normal(scale=0.2, size=7)
        qd = rng.normal(scale=0.5, size=7)
        twist = rng.normal(scale=0.2, size=6)
        plain = ReplicaController(robot, paper_fic()).command(q, qd, position, rotation, twist)
        compensated = ReplicaController(robot, paper_fic(), joint_damping_compensation=True).command(
            q, qd, position, rotation, twist)
        minv = pin.computeMinverse(robot.model, data, q)
        minv = np.triu(minv) + np.triu(minv, 1).T
        jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.tcp_frame_id, pin.LOCAL_WORLD_ALIGNED)
        inertia = np.linalg.inv(jacobian @ minv @ jacobian.T + 1e-3 * np.eye(6))
        expected = JOINT_DAMPING * (minv @ jacobian.T @ inertia @ twist)
        np.testing.assert_allclose(compensated.unshaped_torque - plain.unshaped_torque, expected, atol=1e-8)
        without_twist = ReplicaController(robot, paper_fic(), joint_damping_compensation=True).command(
            q, qd, position, rotation)
        np.testing.assert_allclose(without_twist.unshaped_torque,
                                   ReplicaController(robot, paper_fic()).command(q, qd, position,
                                                                                 rotation).unshaped_torque)


def test_joint_damping_compensation_is_bounded_by_the_friction_at_the_joint_speed_limits(robot: RobotModel) -> None:
    """A desired twist no arm can follow (50 m/s, 200 rad/s) adds at most D qd_max per joint; the same term as an
    unclipped expression would exceed it, so the clip is what bounds it."""
    from fic_core.limits import PANDA_JOINT_VELOCITY_LIMIT
    rng = np.random.default_rng(8)
    position, rotation = nominal_pose(robot)
    bound = JOINT_DAMPING * np.array(PANDA_JOINT_VELOCITY_LIMIT)
    data = robot.model.createData()
    for _ in range(10):
        q = NOMINAL_CONFIGURATION + rng.normal(scale=0.2, size=7)
        qd = rng.normal(scale=0.5, size=7)
        twist = np.concatenate((rng.normal(scale=50.0, size=3), rng.normal(scale=200.0, size=3)))
        plain = ReplicaController(robot, paper_fic()).command(q, qd, position, rotation, twist)
        compensated = ReplicaController(robot, paper_fic(), joint_damping_compensation=True).command(
            q, qd, position, rotation, twist)
        added = compensated.unshaped_torque - plain.unshaped_torque
        assert np.all(np.abs(added) <= bound + 1e-9), (added, bound)
        minv = pin.computeMinverse(robot.model, data, q)
        minv = np.triu(minv) + np.triu(minv, 1).T
        jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.tcp_frame_id, pin.LOCAL_WORLD_ALIGNED)
        inertia = np.linalg.inv(jacobian @ minv @ jacobian.T + 1e-3 * np.eye(6))
        unclipped = JOINT_DAMPING * (minv @ jacobian.T @ inertia @ twist)
        assert np.any(np.abs(unclipped) > bound)


def test_feedforward_produces_the_desired_task_acceleration(robot: RobotModel) -> None:
    """J M^-1 (J^T Lambda (a_d - Jdot qd)) + Jdot qd = a_d up to the regularisation, at random states; a 3-vector
    means zero angular acceleration; the feedforward is part of tau_d."""
    rng = np.random.default_rng(23)
    position, rotation = nominal_pose(robot)
    data = robot.model.createData()
    for _ in range(10):
        q = NOMINAL_CONFIGURATION + rng.normal(scale=0.2, size=7)
        qd = rng.normal(scale=0.3, size=7)
        acceleration = rng.normal(scale=2.0, size=3)
        plain = ReplicaController(robot, paper_fic()).command(q, qd, position, rotation)
        command = ReplicaController(robot, paper_fic()).command(q, qd, position, rotation, None, acceleration)
        six = ReplicaController(robot, paper_fic()).command(q, qd, position, rotation, None,
                                                            np.concatenate((acceleration, np.zeros(3))))
        np.testing.assert_allclose(six.unshaped_torque, command.unshaped_torque, atol=1e-12)
        np.testing.assert_allclose(command.unshaped_torque - plain.unshaped_torque, command.feedforward_torque,
                                   atol=1e-9)
        # The task acceleration it produces, from independent Pinocchio calls.
        minv = pin.computeMinverse(robot.model, data, q)
        jacobian = pin.computeFrameJacobian(robot.model, data, q, robot.tcp_frame_id, pin.LOCAL_WORLD_ALIGNED)
        pin.forwardKinematics(robot.model, data, q, qd, np.zeros(7))
        bias = pin.getFrameClassicalAcceleration(robot.model, data, robot.tcp_frame_id,
                                                 pin.LOCAL_WORLD_ALIGNED).vector
        produced = jacobian @ minv @ command.feedforward_torque + bias
        np.testing.assert_allclose(produced, np.concatenate((acceleration, np.zeros(3))), atol=0.02 * (
            1.0 + np.linalg.norm(acceleration)))


@pytest.mark.parametrize("bad", [np.nan, np.inf])
@pytest.mark.parametrize("size", [3, 6])
def test_non_finite_desired_acceleration_is_rejected(robot: RobotModel, bad: float, size: int) -> None:
    replica = ReplicaController(robot, paper_fic())
    position, rotation = nominal_pose(robot)
    acceleration = np.zeros(size)
    acceleration[1] = bad
    with pytest.raises(FicInputError, match="desired_acceleration"):
        replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation, None, acceleration)
    with pytest.raises(FicInputError, match="desired_acceleration"):
        replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation, None, np.zeros(4))
    assert replica.ticks == 0 and replica.previous_torque is None


def test_report_fields_are_those_of_their_own_tick(robot: RobotModel) -> None:
    """The report fields are computed on read, from the state of the tick that made the command."""
    replica = ReplicaController(robot, paper_fic())
    position, rotation = nominal_pose(robot)
    first = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position + [0.03, 0.0, 0.0], rotation)
    energy, phase = replica.controller.stored_energy.copy(), replica.controller.phase.copy()
    robot_energy = 0.0  # at rest
    second = replica.command(NOMINAL_CONFIGURATION, np.full(7, 0.1), position + [0.01, 0.0, 0.0], rotation)
    np.testing.assert_array_equal(first.stored_energy, energy)
    np.testing.assert_array_equal(first.phase, phase)
    assert first.kinetic_energy == robot_energy and second.kinetic_energy > 0.0
    np.testing.assert_allclose(first.tracking_error, [0.03, 0.0, 0.0], atol=1e-12)
    assert not np.allclose(second.stored_energy, energy)


def test_the_tick_sets_every_field_of_its_command(robot: RobotModel) -> None:
    """The tick fills a bare ReplicaCommand field by field (replica.py says why): none may be left unset, and the
    keyword constructor given the same fields makes a command that reports the same."""
    replica = ReplicaController(robot, paper_fic())
    position, rotation = nominal_pose(robot)
    replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position, rotation)
    command = replica.command(NOMINAL_CONFIGURATION, np.full(7, 0.1), position + [0.02, 0.0, 0.0], rotation,
                              desired_acceleration=np.ones(3))
    values = {item.name: getattr(command, item.name) for item in dataclasses.fields(ReplicaCommand)}
    assert values.pop("_cache") is None
    copy = ReplicaCommand(**values)
    for name in ("posture_torque", "feedforward_torque", "tracking_error", "desired_position", "phase",
                 "latched_max_error", "stored_energy", "torque_ratio", "torque_rate_ratio", "joint_velocity_ratio",
                 "joint_position_margin"):
        np.testing.assert_array_equal(getattr(copy, name), getattr(command, name))
    assert copy.kinetic_energy == command.kinetic_energy > 0.0
    with pytest.raises(TypeError):
        ReplicaCommand(*values.values())  # keyword only


class _ForeignController:
    """A TaskController with only the Protocol's members (no snapshot, no wrench_values)."""

    controller_name = "foreign"

    def __init__(self) -> None:
        self.inner = LinearImpedance(200.0, 20.0, 40.0, 1.0)

    def wrench(self, position_error, rotation_error, twist_error):
        return self.inner.wrench(position_error, rotation_error, twist_error)

    phase = property(lambda self: self.inner.phase)
    latched_max_error = property(lambda self: self.inner.latched_max_error)
    last_force = property(lambda self: self.inner.last_force)
    stored_energy = property(lambda self: self.inner.stored_energy)

    def reset(self) -> None:
        self.inner.reset()


def test_a_controller_with_only_the_protocol_gives_the_same_command(robot: RobotModel) -> None:
    position, rotation = nominal_pose(robot)
    target = position + [0.02, -0.01, 0.0]
    native = ReplicaController(robot, LinearImpedance(200.0, 20.0, 40.0, 1.0)).command(
        NOMINAL_CONFIGURATION, np.full(7, 0.05), target, rotation)
    foreign = ReplicaController(robot, _ForeignController()).command(
        NOMINAL_CONFIGURATION, np.full(7, 0.05), target, rotation)
    np.testing.assert_allclose(foreign.torque, native.torque, atol=1e-12)
    np.testing.assert_allclose(foreign.stored_energy, native.stored_energy, atol=1e-15)


def test_the_commands_ratios_are_each_limits_share_and_never_above_one(robot: RobotModel, limits: PandaLimits) -> None:
    """torque_ratio and torque_rate_ratio report how much of its limit each joint's command uses (|tau| / tau_max,
    |tau - tau_prev| / (rate x interval)): recomputed here, and at most 1 on ticks whose demands drive the torque
    onto its box (the command never breaks either limit)."""
    replica = ReplicaController(robot, paper_fic())
    target, rotation = nominal_pose(robot)
    rng = np.random.default_rng(245)
    largest = 0.0
    for _ in range(40):
        command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), target + rng.normal(scale=0.5, size=3),
                                  rotation)
        np.testing.assert_allclose(command.torque_ratio, np.abs(command.torque) / limits.torque_array, rtol=1e-12)
        assert np.all(command.torque_ratio <= 1.0 + 1e-9) and np.all(command.torque_rate_ratio <= 1.0 + 1e-9)
        largest = max(largest, float(command.torque_ratio.max()))
    assert largest > 0.1


def test_the_feedforward_wrench_solves_its_system_also_when_the_model_is_corrupt(robot: RobotModel) -> None:
    """Lambda a = (J M^-1 J^T + mu I)^-1 a by Cholesky; a corrupt model whose J M^-1 J^T is not positive
    semidefinite makes Cholesky fail, and the wrench is then the least-squares solution of the same system."""
    replica = ReplicaController(robot, paper_fic())
    acceleration = np.array([0.3, -0.2, 0.1, 0.5, 0.0, -0.4])
    rng = np.random.default_rng(673)
    basis = np.linalg.qr(rng.normal(size=(6, 6)))[0]
    for eigenvalues in ((2.0, 1.0, 0.5, 0.3, 0.2, 0.1), (2.0, -1.0, 0.5, -0.3, 0.2, 0.1)):
        task_inverse_inertia = basis @ np.diag(eigenvalues) @ basis.T
        wrench = replica._feedforward_wrench(task_inverse_inertia, acceleration)
        matrix = task_inverse_inertia + replica.feedforward_regularisation * np.eye(6)
        np.testing.assert_allclose(matrix @ wrench, acceleration, atol=1e-9)


def test_an_optimisation_for_another_control_period_is_refused(robot: RobotModel, limits: PandaLimits) -> None:
    """The postural optimisation predicts one control period ahead: one built for 2 ms cannot shape a 1 ms law's
    torques (nor one for 1.5 ms); the same period is taken."""
    from fic_core.postural_optimisation import PosturalOptimisation

    for period in (0.002, 0.0015):
        with pytest.raises(FicInputError, match="control_period must equal"):
            ReplicaController(robot, paper_fic(), control_period=DT, optimisation=PosturalOptimisation(limits, period))
    replica = ReplicaController(robot, paper_fic(), control_period=DT, optimisation=PosturalOptimisation(limits, DT))
    assert replica.optimisation.control_period == DT


def test_the_joint_velocity_ratio_is_each_joints_share_of_its_limit(robot: RobotModel, limits: PandaLimits) -> None:
    """|qd_i| / qd_max_i of the measured state: half of every limit, either way, reads 0.5 on every joint."""
    replica = ReplicaController(robot, paper_fic())
    target, rotation = nominal_pose(robot)
    qd = 0.5 * limits.joint_velocity_array * np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0])
    command = replica.command(NOMINAL_CONFIGURATION, qd, target, rotation)
    np.testing.assert_allclose(command.joint_velocity_ratio, 0.5, rtol=1e-12)


def test_every_joint_past_a_limit_is_flagged(robot: RobotModel, limits: PandaLimits) -> None:
    """The measured state breaks a limit on every joint at once: all seven at 1.2 x v_max, or all seven 0.01 rad
    past their upper position limits at rest (the TCP slow): the command says so, as limits.py recomputes it."""
    target, rotation = nominal_pose(robot)
    beyond = robot.upper_position_limit + 0.01
    for q, qd, flag in ((NOMINAL_CONFIGURATION, 1.2 * limits.joint_velocity_array, LimitFlag.JOINT_VELOCITY),
                        (beyond, np.zeros(7), LimitFlag.JOINT_POSITION)):
        replica = ReplicaController(robot, paper_fic())
        command = replica.command(q, qd, target, rotation)
        assert command.limit_violations & flag, flag
        assert command.limit_violations == limit_violations(None, command.torque, q, qd, command.tcp_speed, DT,
                                                            limits)
