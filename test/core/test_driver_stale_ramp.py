"""The replica's joint-state ramp-down (docs/HARDWARE.md, Watchdogs) with gravity in the command: when the arm leaves
G(q) to the command (the simulated Panda's semantics, config/replica.yaml) and the joint states stop, the command
still ramps linearly over ``torque_ramp_time`` from the last one sent to the gravity-only hold G(q) at the last
state, as it ramps to zero on an arm that compensates gravity itself. Without the ramp a forward controller would
hold the last torque forever."""
from __future__ import annotations

import numpy as np
import pytest
from config_values import config_values

from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.replica_driver import DRIVER_PARAMETERS, DriverParameters, ReplicaDriver


@pytest.mark.parametrize("gravity_compensated_by_robot", [False, True])
def test_stale_joint_states_ramp_to_the_gravity_only_hold(robot, gravity_compensated_by_robot: bool) -> None:
    values = {**config_values("replica.yaml"), "joint_state_timeout": 0.0625, "torque_ramp_time": 0.5,
              "gravity_compensated_by_robot": gravity_compensated_by_robot}
    driver = ReplicaDriver(DriverParameters.from_values({name: values[name] for name in DRIVER_PARAMETERS}))
    robot.update(NOMINAL_CONFIGURATION + 0.1, np.zeros(7))
    gravity = robot.gravity
    rest = np.zeros(7) if gravity_compensated_by_robot else gravity
    torque = gravity + np.linspace(-3.0, 3.0, 7)
    driver.ramp.fresh(1.0)
    sent = driver.command_to_send(torque, robot)
    np.testing.assert_allclose(sent, torque - gravity if gravity_compensated_by_robot else torque)
    assert driver.ramp_command(1.0625) == (None, False)        # at the timeout: still fresh
    start, started = driver.ramp_command(1.125)
    assert started
    np.testing.assert_allclose(start, sent)                    # the ramp starts from the last command sent
    assert driver.command_to_send(torque, robot) is None       # the ramp owns the command until a fresh state
    middle, started = driver.ramp_command(1.375)
    assert not started
    np.testing.assert_allclose(middle, 0.5 * (sent + rest))
    end, _ = driver.ramp_command(2.0)
    np.testing.assert_allclose(end, rest)
    np.testing.assert_allclose(driver.published, rest)
