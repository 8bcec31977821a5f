"""The simulated robot's station (sim_bridge.robot.robot_station): the hold before the first torque and once the
torques go stale, the refusal of a torque on an old state, the velocity reflex that latches the hold, the hold left
to a forward controller's semantics, and the physics-rate dynamics, each on the MuJoCo Panda."""
from __future__ import annotations

import math

import numpy as np
import pytest
from config_values import config_values

from fic_core.arm_profile import arm_profile
from fic_core.panda_description import ARM_JOINT_NAMES
from sim_bridge.robot.mujoco_panda import PandaSimulation
from sim_bridge.robot.robot_parameters import RobotParameters
from sim_bridge.robot.robot_station import RobotStation
from sim_bridge.robot.velocity_reflex import VelocityReflex

STEP = 0.001
PUSH = np.array([5.0, 0, 0, 0, 0, 0, 0])   # on joint 1, beside the hold torque [N m]


def _station(**options) -> RobotStation:
    return RobotStation(PandaSimulation("free_space", 0), command_timeout=0.05, **options)


def test_it_holds_before_the_first_torque_and_follows_a_received_one() -> None:
    robot = _station()
    held = robot.torque()
    assert robot.holding and robot.command is None
    np.testing.assert_array_equal(held, robot.sim.hold_torque())
    update = robot.update(0.0)
    assert update.watchdog is not None and update.watchdog.engaged and update.reflex is None
    torque = robot.sim.hold_torque() + PUSH
    event = robot.receive(torque, 0.001)
    assert event is not None and not event.engaged and not robot.holding
    robot.update(0.001)
    np.testing.assert_allclose(robot.sim.applied_torque, torque)


def test_a_stale_torque_is_replaced_by_the_hold_and_a_fresh_one_ends_it() -> None:
    robot = _station()
    robot.receive(robot.sim.hold_torque() + PUSH, 0.0)
    events = [robot.update(k * STEP).watchdog for k in range(100)]
    engaged = [event for event in events if event is not None]
    assert len(engaged) == 1 and engaged[0].engaged and engaged[0].time == pytest.approx(0.051)
    assert robot.holding and robot.watchdog_engagements == 1
    np.testing.assert_array_equal(robot.torque(), robot.sim.hold_torque())   # no longer the pushing torque
    assert robot.receive(robot.sim.hold_torque(), 0.1) is not None and not robot.holding


def test_without_hold_on_stale_the_last_torque_is_applied_on() -> None:
    robot = _station(hold_on_stale=False)
    torque = robot.sim.hold_torque() + PUSH
    robot.receive(torque, 0.0)
    for k in range(100):
        robot.update(k * STEP)
    assert robot.holding
    np.testing.assert_array_equal(robot.torque(), torque)


def test_a_torque_on_a_state_older_than_the_bound_is_refused_and_counted() -> None:
    robot = _station(command_state_timeout=0.05)
    assert robot.admits(0.96, 1.0) and robot.refused_torques == 0
    assert not robot.admits(0.9, 1.0) and robot.refused_torques == 1
    assert _station().admits(-1e9, 1.0)   # no bound: every state admitted


def test_the_velocity_reflex_latches_the_hold_whatever_is_commanded() -> None:
    """A torque that drives joint 1 past its limit: the reflex trips once, and from then on the arm gets the hold
    torque though the pushing torque keeps coming; it comes to rest."""
    robot = _station(reflex=VelocityReflex(arm_profile("panda").joint_velocity, ARM_JOINT_NAMES))
    push = np.array([60.0, 0, 0, 0, 0, 0, 0])
    trips = []
    for k in range(1500):
        robot.receive(robot.sim.hold_torque() + push, k * STEP)
        update = robot.update(k * STEP)
        if update.reflex is not None:
            trips.append(update.reflex)
    assert len(trips) == 1 and trips[0].joint == "panda_joint1" and robot.reflex_tripped
    assert robot.reflex_event is trips[0]
    assert abs(robot.sim.joint_velocities[0]) < 0.05
    assert 2.175 < robot.joint_speed_max < 2.175 * 1.2


def test_the_physics_rate_dynamics_swap_the_ticks_bias_for_the_arms_own() -> None:
    """dynamics_at_physics_rate: the torque applied is the law's minus its tick's C qd + G plus the arm's own at the
    step it arrives; a torque held between ticks keeps the last tick's."""
    robot = RobotStation(PandaSimulation("free_space", 0, gravity_compensation=True), command_timeout=0.05,
                         dynamics_at_physics_rate=True)
    tick = np.full(7, 0.5)
    own = robot.sim.hold_torque(np.zeros(7))
    robot.receive(PUSH, 0.0, tick)
    np.testing.assert_allclose(robot.command, PUSH - tick + own)
    robot.update(0.0)
    own = robot.sim.hold_torque(np.zeros(7))
    robot.receive(PUSH, 0.001)   # between ticks: the same tick's C qd + G
    np.testing.assert_allclose(robot.command, PUSH - tick + own)


def test_the_arms_kinetic_energy_and_the_contacts_of_a_geom() -> None:
    robot = RobotStation(PandaSimulation("superimposition", 0), command_timeout=0.05)
    assert robot.arm_kinetic_energy() == 0.0
    robot.receive(robot.sim.hold_torque() + PUSH, 0.0)
    for k in range(50):
        robot.update(k * STEP)
    assert robot.arm_kinetic_energy() > 0.0
    # The pushable obstacle rests on the table; the fixed one (static) touches nothing but the robot.
    assert robot.touches("pushable_obstacle") and not robot.touches("fixed_obstacle")


def test_the_node_and_the_runner_build_it_from_the_robots_parameters() -> None:
    """RobotStation.from_parameters: config/robot.yaml's values as the typed object robot_node declares; the
    state-age bound on the node's nanosecond stamp grid or in the runner's seconds, or none (the robot before the
    rule); the hold as the parameters say."""
    parameters = RobotParameters.from_values(config_values("robot.yaml"))
    sim = PandaSimulation("free_space", 0)
    node = RobotStation.from_parameters(sim, parameters, ARM_JOINT_NAMES, nanosecond_stamps=True)
    assert node.command_timeout == parameters.command_timeout and node.hold_on_stale
    assert node.command_state_timeout == round(parameters.command_state_timeout * 1e9)
    assert isinstance(node.command_state_timeout, int)
    runner = RobotStation.from_parameters(sim, parameters.replaced({"hold_on_stale_commands": False}),
                                          ARM_JOINT_NAMES)
    assert runner.command_state_timeout == parameters.command_state_timeout and not runner.hold_on_stale
    assert RobotStation.from_parameters(sim, parameters, ARM_JOINT_NAMES,
                                        state_age_rule=False).command_state_timeout == math.inf
