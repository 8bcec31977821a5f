"""Bad torque commands never reach the physics; good ones are clamped to the Franka limits."""
import numpy as np
import pytest

from fic_core.errors import FicInputError
from sim_bridge.robot.mujoco_panda import TORQUE_LIMITS, PandaSimulation


@pytest.mark.parametrize("torque", [
    [np.nan, 0, 0, 0, 0, 0, 0],
    [0, 0, 0, np.inf, 0, 0, 0],
    [0, 0, 0, 0, 0, 0, -np.inf],
    [0.0] * 6,
    [0.0] * 8,
    [[0.0] * 7],
    ["a"] * 7,
])
def test_invalid_torque_is_rejected_and_the_state_is_untouched(torque):
    sim = PandaSimulation("free_space", seed=0)
    for _ in range(5):
        sim.step(sim.hold_torque())
    before = (sim.time, sim.joint_positions, sim.joint_velocities, sim.applied_torque)
    with pytest.raises(ValueError) as error:
        sim.step(torque)
    assert isinstance(error.value, FicInputError)
    assert "torque" in str(error.value)
    assert sim.time == before[0]
    np.testing.assert_array_equal(sim.joint_positions, before[1])
    np.testing.assert_array_equal(sim.joint_velocities, before[2])
    np.testing.assert_array_equal(sim.applied_torque, before[3])


def test_large_torque_is_clamped_to_the_limits():
    sim = PandaSimulation("free_space", seed=0)
    sim.step(np.array([500.0, -500.0, 100.0, -88.0, 13.0, -1e9, 11.0]))
    np.testing.assert_array_equal(sim.applied_torque, [87.0, -87.0, 87.0, -87.0, 12.0, -12.0, 11.0])
    np.testing.assert_array_equal(sim.data.ctrl[:7], sim.applied_torque)
    assert np.all(np.abs(sim.applied_torque) <= TORQUE_LIMITS)
