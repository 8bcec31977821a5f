"""The simulated arm can compensate its own gravity at its physics rate, as a Franka under torque control does."""
from __future__ import annotations

import numpy as np

from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.robot_model import RobotModel
from fic_core.torque_semantics import TorqueSemantics
from sim_bridge.robot.mujoco_panda import PandaSimulation


def _run(sim: PandaSimulation, torque_of, steps: int) -> np.ndarray:
    for _ in range(steps):
        sim.step(torque_of(sim.joint_positions, sim.joint_velocities))
    return sim.joint_positions


def test_zero_torque_floats_with_compensation_and_falls_without():
    floating = _run(PandaSimulation("free_space", 0, gravity_compensation=True), lambda q, qd: np.zeros(7), 1000)
    falling = _run(PandaSimulation("free_space", 0), lambda q, qd: np.zeros(7), 1000)
    assert np.abs(floating - NOMINAL_CONFIGURATION).max() < 1e-3
    assert np.abs(falling - NOMINAL_CONFIGURATION).max() > 0.1


def test_both_semantics_move_the_arm_alike():
    """Eq. 7's tau on the plain arm and tau - G(q) on the self-compensating arm: the same motion (the two
    gravity models are the same URDF; what is left is integration order)."""
    robot = RobotModel()
    target = NOMINAL_CONFIGURATION + np.array([0.3, -0.2, 0.2, 0.3, 0.0, -0.2, 0.3])

    def law(semantics: TorqueSemantics):
        def torque(q, qd):
            robot.update(q, qd)
            tau = robot.nonlinear_effects + 40.0 * (target - q) - 8.0 * qd  # C qd + G + joint PD
            return semantics.command(tau, robot.gravity)
        return torque

    plain = _run(PandaSimulation("free_space", 0), law(TorqueSemantics(False)), 800)
    compensated = _run(PandaSimulation("free_space", 0, gravity_compensation=True), law(TorqueSemantics(True)), 800)
    assert np.abs(plain - NOMINAL_CONFIGURATION).max() > 0.1  # it moved
    assert np.abs(plain - compensated).max() < 2e-3


def test_hold_torque_leaves_gravity_to_the_arm():
    sim = PandaSimulation("free_space", 0, gravity_compensation=True)
    held = _run(sim, lambda q, qd: sim.hold_torque(), 500)
    assert np.abs(held - NOMINAL_CONFIGURATION).max() < 1e-3
    assert np.abs(sim.hold_torque()).max() < 1e-2  # no G in it: the arm at rest needs nothing
