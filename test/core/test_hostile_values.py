"""Hostile but finite inputs at the core: offsets of 1e3 m and 1e308, stamps far in the future and in the past.

What must hold (docs/SECURITY.md's threat: anyone on the domain can publish): nothing raises but a FicInputError
(a refusal the node turns into one log line and a hold), nothing becomes NaN or Inf, one bad stamp does not
disable the feedforward for good, and the arm (MuJoCo's, closing the loop with ReplicaController) stays inside
every Panda limit.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from config_values import config_values, replica_loop_parameters

from fic_core.errors import FicInputError
from fic_core.input_authority import AUTHORITY_PARAMETERS, AuthorityBounds, AuthorityParameters, CommandAuthority
from fic_core.limits import LimitFlag, PandaLimits
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel
from fic_core.set_point import SampledSetPoint

#: The replica's shipped parameters (the input authority's bounds among them).
REPLICA_DEFAULTS = config_values("replica.yaml")

HOSTILE_OFFSETS = (1e3, -1e3, 1e308, -1e308, 1.7e308)
DT = 0.001


def assert_finite_hold(hold: SampledSetPoint, now: float) -> None:
    position, velocity, acceleration = hold.position(now), hold.velocity(now), hold.acceleration(now)
    assert np.isfinite(position).all() and np.isfinite(velocity).all() and np.isfinite(acceleration).all()
    assert np.linalg.norm(velocity) <= hold.max_speed * (1 + 1e-12)
    assert np.linalg.norm(acceleration) <= hold.max_acceleration * (1 + 1e-12)


@pytest.mark.parametrize("hostile", HOSTILE_OFFSETS)
def test_a_huge_sample_never_makes_the_hold_non_finite(hostile: float) -> None:
    hold = SampledSetPoint()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an overflow inside the hold is a bug, even if it were masked later
        for tick in range(10):
            hold.add(0.01 * tick, [0.001 * tick, 0.0, 0.0], 0.01 * tick)
        for tick, value in enumerate((hostile, -hostile, hostile, 0.0, 0.0)):
            now = 0.1 + 0.01 * tick
            hold.add(now, [value, -value, 0.5 * value], now)
            for later in (now, now + 0.005, now + 0.02, now + 1.0):
                assert_finite_hold(hold, later)


@pytest.mark.parametrize("stamp", [1e9, 1e308, -1e9, -1e308, 0.0])
def test_one_stamp_far_off_does_not_freeze_the_estimates(stamp: float) -> None:
    """A ramp at 0.1 m/s sampled at 100 Hz, stamps near 1000 s; one sample with a stamp far in the future or the
    past (or epoch 0) in the middle: a few samples later the velocity is the ramp's again."""
    hold = SampledSetPoint(acceleration_time_constant=0.0)
    base = 1000.0

    def ramp(tick: int) -> None:
        hold.add(base + 0.01 * tick, [0.001 * tick, 0.0, 0.0], base + 0.01 * tick)

    for tick in range(20):
        ramp(tick)
    np.testing.assert_allclose(hold.velocity(base + 0.195), [0.1, 0.0, 0.0], atol=1e-9)
    hold.add(stamp, [0.02, 0.0, 0.0], base + 0.2)
    assert_finite_hold(hold, base + 0.2)
    for tick in range(21, 25):
        ramp(tick)
        assert_finite_hold(hold, base + 0.01 * tick)
    np.testing.assert_allclose(hold.velocity(base + 0.245), [0.1, 0.0, 0.0], atol=1e-9)


# The replica's one-sum finiteness check overflows for 1e308 inputs by design (it then checks in full).
@pytest.mark.filterwarnings("ignore:overflow encountered in reduce:RuntimeWarning")
@pytest.mark.parametrize("hostile", HOSTILE_OFFSETS)
def test_the_replica_law_refuses_or_answers_inside_the_limits(robot: RobotModel, hostile: float) -> None:
    """x_d at hostile distances, with hostile twists and accelerations: a torque inside the limits, or a
    FicInputError before any state changes (the node then holds)."""
    limits = PandaLimits.from_robot(robot)
    replica = ReplicaController(robot, PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 30.0),
                                                     ForceProfile(20.0, 0.5, 0.5, 10.0)),
                                joint_damping_compensation=True, feedforward_limit=(30.0, 10.0))
    from fic_core.panda_description import NOMINAL_CONFIGURATION
    robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    position, rotation = robot.tcp_position.copy(), robot.tcp_rotation.copy()
    command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position + hostile, rotation)
    assert np.all(np.abs(command.torque) <= limits.torque_array + 1e-9)
    assert command.limit_violations == LimitFlag.NONE
    assert np.linalg.norm(command.wrench[:3]) <= 30.0 * np.sqrt(3.0) + 1e-9  # F_max per axis: bounded force
    for twist, acceleration in ((np.full(6, hostile), None), (None, np.full(3, hostile))):
        ticks = replica.ticks
        try:
            command = replica.command(NOMINAL_CONFIGURATION, np.zeros(7), position + hostile, rotation, twist,
                                      acceleration)
        except FicInputError:
            assert replica.ticks == ticks  # refused before any state changed
            continue
        assert np.all(np.isfinite(command.torque))
        assert np.all(np.abs(command.torque) <= limits.torque_array + 1e-9)


def _assert_inside_limits(sim, limits: PandaLimits, previous_torque: np.ndarray | None) -> np.ndarray:
    """MuJoCo's applied torque inside the torque and torque-rate limits, its joints inside position and velocity
    limits, after one step; returns the torque (the next step's ``previous_torque``)."""
    torque = sim.applied_torque
    assert np.all(np.abs(torque) <= limits.torque_array + 1e-9)
    if previous_torque is not None:
        assert np.all(np.abs(torque - previous_torque) <= limits.torque_rate * DT + 1e-6)
    q, qd = sim.joint_positions, sim.joint_velocities
    assert np.all(q >= limits.lower_array - 1e-6) and np.all(q <= limits.upper_array + 1e-6)
    assert np.all(np.abs(qd) <= limits.joint_velocity_array + 1e-6)
    return torque.copy()


@pytest.mark.parametrize("hostile", [1e3, 1e308])
def test_mujoco_arm_under_a_hostile_offset_stays_inside_its_limits(robot: RobotModel, hostile: float) -> None:
    """x_d = start + the hold of a hostile x_d' stream (one huge sample, then far-off stamps), ReplicaController on
    the MuJoCo arm for 1.5 s: every tick answers, and MuJoCo's joints stay inside every limit."""
    from sim_bridge.robot.mujoco_panda import PandaSimulation

    limits = PandaLimits.from_robot(robot)
    sim = PandaSimulation("free_space", 0)
    start, rotation = sim.tcp_pose
    start = start.copy()
    replica = ReplicaController(robot, PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 30.0),
                                                     ForceProfile(20.0, 0.5, 0.5, 10.0)),
                                joint_damping_compensation=True, feedforward_limit=(30.0, 10.0))
    hold = SampledSetPoint()
    samples = {100: (0.0, 0.1), 300: (hostile, 0.3), 400: (-hostile, 1e308), 500: (0.0, -1e308), 600: (0.01, 0.6)}
    refused = 0
    previous_torque = None
    for tick in range(1500):
        now = tick * DT
        if tick in samples:
            value, stamp = samples[tick]
            hold.add(stamp, [value, 0.0, value], now)
        offset = hold.position(now) if hold.has_sample else np.zeros(3)
        try:
            command = replica.command(sim.joint_positions, sim.joint_velocities, start + offset, rotation, None,
                                      hold.acceleration(now) if hold.has_sample else None)
        except FicInputError:
            refused += 1
            command = replica.hold(sim.joint_positions, sim.joint_velocities)
        sim.step(command.torque)
        previous_torque = _assert_inside_limits(sim, limits, previous_torque)
    assert refused == 0


@pytest.mark.filterwarnings("ignore:overflow encountered in reduce:RuntimeWarning")
@pytest.mark.parametrize("hostile", [
    # Without the input authority in front of the loop, x_d' = 1e3 m reached the law unbounded, the arm was driven
    # at its velocity limits toward it and MuJoCo's joint 6 reached 2.6106 rad/s against 2.61 (2026-12-02).
    1e3, 1e308])
def test_the_replica_loop_on_mujoco_survives_hostile_commands_inside_its_limits(robot: RobotModel,
                                                                                  hostile: float) -> None:
    """The replica node's whole logic (fic_core.input_authority.CommandAuthority in front of
    fic_core.replica_loop.ReplicaLoop, what the node wires to its topics, with the node's defaults) closing the loop on
    the MuJoCo arm at 1 kHz for 2 s, fed 100 Hz teleoperation commands: normal ones, then a hostile offset, its
    negative, stamps 1e9 s ahead, at epoch 0 and 1e308, and normal ones again. Every joint state is answered with a
    finite torque (a refused command raises FicInputError only at its input), MuJoCo's arm stays inside every limit, and
    the offset feedforward works again at the end."""
    from fic_core.replica_loop import ReplicaLoop
    from sim_bridge.robot.mujoco_panda import PandaSimulation

    limits = PandaLimits.from_robot(robot)
    sim = PandaSimulation("free_space", 0)
    loop = ReplicaLoop(replica_loop_parameters(answer_every_state=True), robot)
    authority = CommandAuthority(AuthorityBounds.from_parameters(AuthorityParameters.from_values(
        {name: REPLICA_DEFAULTS[name] for name in AUTHORITY_PARAMETERS})))
    base = 1000.0
    hostile_commands = {60: (hostile, 0.0), 61: (-hostile, 0.0), 62: (0.0, 1e9), 63: (0.0, -base),
                        64: (0.0, 1e308 - base), 65: (hostile, 1e9)}
    refused = 0
    previous = None
    for tick in range(2000):
        time = base + tick * DT
        if tick % 10 == 0:
            command = tick // 10
            value, stamp_shift = hostile_commands.get(command, (0.0005 * command, 0.0))
            stamp_ns = int(min((time + stamp_shift) * 1e9, 2 ** 63 - 1))
            verdict = authority.check(stamp=stamp_ns * 1e-9, now=time, mode=0, haptic_gain=0.5, workspace_scale=1.0,
                                      velocity_gain=2.0, handle_position=(0.0, 0.0, 0.0),
                                      desired_offset=(value, 0.0, 0.0))
            if not verdict.accepted:
                refused += 1
                continue
            try:
                loop.add_teleoperation(stamp_ns, verdict.offset, time)
            except FicInputError:
                refused += 1
        step = loop.joint_state(time, time, sim.joint_positions, sim.joint_velocities)
        assert step.torque is not None and np.all(np.isfinite(step.torque))
        sim.step(step.torque)
        previous = _assert_inside_limits(sim, limits, previous)
    assert loop.counts["control_ticks"] > 0
    assert refused <= len(hostile_commands)
