"""Edges of fic_core's inputs and of its small numerical promises, where the seeded random mutation run
(fic_teleop_experiments.tools.random_mutation) found operator flips that no other test caught: parameter ranges at their
ends, the flat via-point list, the attractor's snapshot, the force profile's inverse storage and its secant stiffness
just past a tiny linear region."""
from __future__ import annotations

import math

import numpy as np
import pytest
from config_values import config_values

from fic_core.attractor import FractalAttractor, convergence_storage
from fic_core.control_schedule import RateGate
from fic_core.errors import FicInputError
from fic_core.input_authority import AuthorityBounds
from fic_core.master_station import MASTER_NUMBERS, MasterParameters, MasterStation
from fic_core.profile import ForceProfile
from fic_core.trajectories import ViaPoints


def test_a_rate_gate_needs_a_positive_rate_and_period() -> None:
    for rate, period in ((0.0, 0.002), (100.0, 0.0), (-1.0, 0.002)):
        with pytest.raises(FicInputError):
            RateGate(rate, period)
    gate = RateGate(100.0, 0.002)
    assert gate.due(0.0)


@pytest.mark.parametrize("name", ["workspace_scale", "velocity_gain"])
def test_every_value_the_master_may_be_set_to_passes_the_replicas_authority(name: str) -> None:
    """The master node's parameter range (MASTER_NUMBERS, its descriptors) inside the replica's authority bound on
    the same figure: else a master set within its own range would be refused by the replica. Both ends pass. The
    bound is that range exactly ("the master's parameter range"): a wider one would take a figure no master sends."""
    low, high = MASTER_NUMBERS[name].low, MASTER_NUMBERS[name].high
    bound_low, bound_high = getattr(AuthorityBounds(), name)
    assert (bound_low, bound_high) == (low, high)
    defaults = {**config_values("master.yaml"), "haptic_gain": 0.0}  # K_H = 0: the loop-gain bound spares s_M
    for value in (low, high):
        assert getattr(MasterStation(MasterParameters.from_values({**defaults, name: value})).integrator, name) == value


def test_via_points_as_one_flat_list() -> None:
    """A ROS double-array parameter: x0, y0, z0, x1, y1, z1 is two via-points."""
    flat = ViaPoints([0.1, 0.2, 0.3, 0.4, 0.5, 0.6], dwell_s=1.0)
    nested = ViaPoints([[0.1, 0.2, 0.3], [0.4, 0.5, 0.6]], dwell_s=1.0)
    for t in (0.0, 0.5, 1.5, 3.0):
        np.testing.assert_array_equal(flat.point(t), nested.point(t))
    with pytest.raises(FicInputError):
        ViaPoints([0.1, 0.2, 0.3, 0.4])


def test_the_snapshot_keeps_the_errors_and_forces_of_its_tick() -> None:
    attractor = FractalAttractor(ForceProfile(200.0, 0.05, 0.5, 30.0), 3, 0.005)
    forces = attractor.force(np.array([0.01, -0.02, 0.03]), np.zeros(3))
    snapshot = attractor.snapshot()
    np.testing.assert_array_equal(snapshot.errors, [0.01, -0.02, 0.03])
    np.testing.assert_array_equal(snapshot.forces, forces)
    attractor.force(np.array([0.02, 0.0, 0.0]), np.zeros(3))
    np.testing.assert_array_equal(snapshot.errors, [0.01, -0.02, 0.03])


def test_convergence_storage_without_stiffness_is_the_latched_energy() -> None:
    """K_C = 0 (nothing latched): V_C stays at the latched storage, whatever the error."""
    profile = ForceProfile(200.0, 0.05, 0.5, 30.0)
    assert convergence_storage(profile, 0.0, 0.0, 0.125, 0.03) == 0.125
    assert convergence_storage(profile, 0.0, 0.0, 0.0, -0.2) == 0.0


@pytest.mark.parametrize("fraction", [0.3, 0.999, 1.0, 1.7, 4.0, 25.0])
def test_the_inverse_storage_rounds_towards_the_smaller_storage(fraction: float) -> None:
    """V_D(energy_inverse(E)) <= E, also in the saturated region where Newton's result is rounded down; and the
    result is that close to the exact inverse."""
    profile = ForceProfile(200.0, 0.05, 0.5, 30.0)
    energy = fraction * float(profile.energy(profile.saturation_error))
    magnitude = profile.energy_inverse(energy)
    assert float(profile.energy(magnitude)) <= energy
    assert float(profile.energy(magnitude * (1.0 + 1e-9))) > energy or magnitude == 0.0


@pytest.mark.parametrize("saturation_start", [0.0, 1e-12, 1e-10])
def test_the_scalar_secant_stiffness_agrees_with_the_array_one_near_zero(saturation_start: float) -> None:
    """The replica's float path and the array path give F_c(e)/e alike, also just past a tiny linear region
    (there both use the profile's tangent at xi x_b)."""
    profile = ForceProfile(200.0, 0.05, saturation_start, 30.0)
    for magnitude in (0.0, 1e-13, 1e-12, 3e-12, 1e-11, 4e-11, 1e-6, 0.02, 0.2):
        scalar = profile.scalar_secant_stiffness(magnitude)
        array = float(profile.secant_stiffness(magnitude))
        assert math.isclose(scalar, array, rel_tol=1e-9), (magnitude, scalar, array)


def test_the_shipped_master_values_lie_inside_their_declared_ranges() -> None:
    """config/master.yaml against MASTER_NUMBERS (the master node's descriptors refuse a value outside): each
    shipped value inside its range, each range non-empty."""
    values = config_values("master.yaml")
    for name, row in MASTER_NUMBERS.items():
        low, high = row.low, row.high
        assert low < high, name
        if name in values:
            assert low <= values[name] <= high, (name, values[name], low, high)


def test_the_planners_feedforward_is_used_up_to_50_ms_old_inclusive() -> None:
    """The planner's acceleration is fed forward while at most FEEDFORWARD_TIMEOUT_S old: at exactly that age
    still, a microsecond later no more."""
    from fic_core.desired_pose import FEEDFORWARD_TIMEOUT_S, DesiredPose, DesiredPoseParameters

    pose = DesiredPose(DesiredPoseParameters(offset_feedforward=False))
    pose.start(np.array([0.3, 0.0, 0.5]), np.eye(3))
    pose.add_planner_pose(0, [0.3, 0.0, 0.5], np.eye(3), 0.0)
    pose.add_planner_acceleration([1.0, 0.0, 0.0], 0.0)
    assert FEEDFORWARD_TIMEOUT_S - 0.0 == FEEDFORWARD_TIMEOUT_S
    np.testing.assert_array_equal(pose.update(FEEDFORWARD_TIMEOUT_S, 0.001).acceleration, [1.0, 0.0, 0.0])
    assert pose.update(FEEDFORWARD_TIMEOUT_S + 1e-6, 0.001).acceleration is None


def test_a_slow_stream_below_one_hertz_is_gated_at_its_own_rate() -> None:
    """A status stream at 0.5 Hz: due at once, again 2 s later (less half a command period), not before."""
    gate = RateGate(0.5, 0.002)
    assert gate.take(10.0)
    assert not gate.take(11.0) and not gate.take(11.9985)
    assert gate.take(11.999)


def test_zero_periods_and_timeouts_are_refused(limits) -> None:
    """A period or timeout of zero would divide by zero or expire every sample at once: each is refused."""
    from fic_core.desired_pose import DesiredPoseParameters
    from fic_core.postural_optimisation import PosturalOptimisation

    with pytest.raises(FicInputError, match="master_timeout"):
        DesiredPoseParameters(master_timeout=0.0)
    with pytest.raises(FicInputError, match="resume_speed"):
        DesiredPoseParameters(resume_speed=0.0)
    with pytest.raises(FicInputError, match="control_period"):
        PosturalOptimisation(limits, 0.0)
    with pytest.raises(FicInputError, match="velocity_horizon"):
        PosturalOptimisation(limits, 0.001, velocity_horizon=0.0)
    assert PosturalOptimisation(limits, 0.001).control_period == 0.001


@pytest.mark.parametrize("bad", [[], [[1.0] * 7], [[1.0]] * 7])
def test_a_first_command_that_is_not_one_list_of_torques_is_refused(bad) -> None:
    """The relay's very first command has no earlier one to be compared with: an empty or nested list is
    refused on its own, and nothing counts as forwarded."""
    from fic_core.command_watchdog import CommandWatchdog
    from fic_core.torque_semantics import TorqueSemantics

    watchdog = CommandWatchdog(0.05, 0.5, TorqueSemantics(True))
    with pytest.raises(FicInputError, match="non-empty list of joint torques"):
        watchdog.replica_command(bad, 0.0)
    assert watchdog.last_command is None and watchdog.forwarded == 0


def test_the_authority_counts_each_verdict_from_zero() -> None:
    """What the replica reports on /diagnostics: a fresh authority has counted nothing; one accepted command, then
    one jump approached at the offset speed, count one each."""
    from fic_core.input_authority import CommandAuthority

    now = 1.7e9
    authority = CommandAuthority()
    assert (authority.accepted, authority.refused, authority.clamped, authority.rate_limited) == (0, 0, 0, 0)
    base = dict(mode=0, haptic_gain=0.5, workspace_scale=1.0, velocity_gain=2.0, handle_position=[0.0, 0.0, 0.0])
    assert authority.check(stamp=now - 0.2, now=now, desired_offset=[0.0, 0.0, 0.0], **base).accepted
    assert (authority.accepted, authority.rate_limited, authority.clamped) == (1, 0, 0)
    jump = authority.check(stamp=now - 0.19, now=now + 0.01, desired_offset=[0.3, 0.0, 0.0], **base)
    assert jump.rate_limited and not jump.clamped
    assert (authority.accepted, authority.rate_limited, authority.clamped, authority.refused) == (2, 1, 0, 0)


def test_a_joint_range_of_zero_width_is_refused() -> None:
    from fic_core.posture import NullSpacePosture

    lower, upper = np.full(7, -1.0), np.full(7, 1.0)
    upper[2] = lower[2]
    with pytest.raises(FicInputError, match="lower_limit must be below upper_limit"):
        NullSpacePosture(lower, upper)
    upper[2] = lower[2] + 1e-6
    assert NullSpacePosture(lower, upper).upper_limit[2] > NullSpacePosture(lower, upper).lower_limit[2]


def test_the_windowed_rate_spans_the_whole_window() -> None:
    """(newest total - total at the window's start) / their time apart, not from a sample inside the window."""
    from fic_core.windowed_rate import WindowedRate

    rate = WindowedRate(10.0)
    for time, total in ((0.0, 0.0), (1.0, 1.0), (2.0, 4.0)):
        rate.add(time, total)
    assert rate.rate == 2.0


def test_the_wrench_frame_cannot_be_changed_once_made() -> None:
    """The frame the replica reads F_R with is set at start (a sign or frame change is a new WrenchFrame)."""
    import dataclasses

    from fic_core.wrench_frame import WrenchFrame

    frame = WrenchFrame()
    with pytest.raises(dataclasses.FrozenInstanceError):
        frame.sign = -1.0
    assert frame.sign == 1.0


def test_a_button_that_first_appears_pressed_is_a_press() -> None:
    """A joystick message longer than the last one: its new buttons count as released before."""
    from fic_core.operator_buttons import ButtonEdges

    edges = ButtonEdges()
    assert edges.pressed([0]) == set()
    assert edges.pressed([0, 1, 1]) == {1, 2}


def test_a_solver_that_reports_success_with_non_finite_values_is_not_trusted(robot, limits, monkeypatch) -> None:
    """daqp saying optimal with NaN in its solution: the optimisation falls back to its last guard (tau_d clipped
    into the torque and torque-rate box), never a NaN torque."""
    import fic_core.postural_optimisation as postural
    from fic_core.limits import LimitFlag
    from fic_core.panda_description import NOMINAL_CONFIGURATION

    calls = []

    def solve(hessian, linear, rows, upper, lower, sense, **_):
        calls.append(len(linear))
        return np.full(len(linear), np.nan), 0.0, 1, {"iterations": 1, "lam": np.zeros(len(upper))}

    monkeypatch.setattr(postural.daqp, "solve", solve)
    optimisation = postural.PosturalOptimisation(limits, 0.001)
    robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    bias = robot.nonlinear_effects + robot.joint_damping * robot.qd
    previous = bias.copy()
    desired = previous.copy()
    desired[1] += 5.0   # past one torque-rate step: the QP is asked
    result = optimisation.shape(desired, previous, robot.q, robot.qd, bias, robot.mass_matrix_inverse,
                                robot.tcp_jacobian[:3])
    assert calls, "the QP was not asked"
    assert np.all(np.isfinite(result.torque))
    assert np.all(np.abs(result.torque - previous) <= limits.torque_rate * 0.001 + 1e-9)
    assert result.flags & LimitFlag.TORQUE_RATE


def test_the_exchanged_energy_watch_books_a_tick_only_with_the_law_that_made_it() -> None:
    """A linear law's tick given with a FIC (a law switched between the tick and its booking) is not booked, nor
    is the FIC's tick given with the linear law: the storage and the snapshot must be the same law's."""
    from config_values import replica_loop_parameters

    from fic_core.exchanged_energy_ports import ReplicaExchangedEnergy
    from fic_core.panda_description import NOMINAL_CONFIGURATION
    from fic_core.replica_loop import ReplicaLoop

    q0 = np.array(NOMINAL_CONFIGURATION, dtype=float)
    commands = {}
    laws = {}
    for controller in ("fic", "linear"):
        loop = ReplicaLoop(replica_loop_parameters(controller=controller, answer_every_state=True))
        step = loop.joint_state(0.0, 0.0, q0, np.zeros(7))
        commands[controller], laws[controller] = step.command, loop.controller.controller
    watch = ReplicaExchangedEnergy(0.001)
    watch.observe(commands["linear"], laws["fic"])
    watch.observe(commands["fic"], laws["linear"])
    assert watch.observer.ticks == 0
    watch.observe(commands["fic"], laws["fic"])
    assert watch.observer.ticks == 1
