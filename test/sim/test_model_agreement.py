"""MuJoCo (the simulated robot) and Pinocchio (the controller's model) are the same robot."""
import mujoco
import numpy as np
import pinocchio as pin

from fic_core.panda_description import load_pinocchio_model
from sim_bridge.robot.mujoco_panda import PandaSimulation


def test_tcp_pose_gravity_coriolis_and_mass_matrix_agree_over_random_states():
    sim = PandaSimulation("free_space", seed=0)
    model, data = sim.model, sim.data
    pin_model, pin_data, tcp_frame = load_pinocchio_model()
    rng = np.random.default_rng(7)
    worst = dict(position=0.0, rotation=0.0, gravity=0.0, coriolis=0.0, mass=0.0)
    for _ in range(300):
        q = rng.uniform(pin_model.lowerPositionLimit, pin_model.upperPositionLimit)
        qd = rng.normal(scale=1.0, size=7)
        data.qpos[:7], data.qvel[:7] = q, qd
        mujoco.mj_forward(model, data)
        position, rotation = sim.tcp_pose
        mass = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, mass)
        coriolis_and_gravity = data.qfrc_bias[:7].copy()
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)
        gravity = data.qfrc_bias[:7].copy()

        pin.forwardKinematics(pin_model, pin_data, q)
        pin.updateFramePlacements(pin_model, pin_data)
        placement = pin_data.oMf[tcp_frame]
        pin_mass = pin.crba(pin_model, pin_data, q)
        pin_mass = np.triu(pin_mass) + np.triu(pin_mass, 1).T
        worst["position"] = max(worst["position"], np.abs(placement.translation - position).max())
        worst["rotation"] = max(worst["rotation"], np.abs(placement.rotation - rotation).max())
        worst["gravity"] = max(worst["gravity"], np.abs(pin.computeGeneralizedGravity(pin_model, pin_data,
                                                                                      q) - gravity).max())
        worst["coriolis"] = max(worst["coriolis"],
                                np.abs(pin.nonLinearEffects(pin_model, pin_data, q, qd) - coriolis_and_gravity).max())
        worst["mass"] = max(worst["mass"], np.abs(pin_mass - mass[:7, :7]).max())
    assert worst["position"] < 1e-9 and worst["rotation"] < 1e-9, worst
    assert worst["gravity"] < 1e-9 and worst["coriolis"] < 1e-9 and worst["mass"] < 1e-9, worst


def test_simulation_uses_the_franka_torque_limits_and_1khz_steps():
    sim = PandaSimulation("free_space", seed=0)
    assert sim.model.opt.timestep == 0.001
    np.testing.assert_array_equal(sim.model.actuator_ctrlrange[:, 1], [87, 87, 87, 87, 12, 12, 12])
    np.testing.assert_array_equal(sim.model.actuator_ctrlrange[:, 0], [-87, -87, -87, -87, -12, -12, -12])
