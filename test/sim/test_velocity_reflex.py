"""The simulated arm's velocity reflex (sim_bridge.robot.velocity_reflex): trips once, on the first joint past its
limit (or a NaN), and latches; on the MuJoCo Panda the hold torque it leaves the arm under brings it to rest."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.arm_profile import arm_profile
from fic_core.errors import FicInputError
from fic_core.panda_description import ARM_JOINT_NAMES
from sim_bridge.robot.mujoco_panda import PandaSimulation
from sim_bridge.robot.velocity_reflex import REFLEX_MARGIN, VelocityReflex

LIMITS = arm_profile("panda").joint_velocity


def test_it_trips_once_on_the_first_joint_past_its_limit_and_margin_and_latches() -> None:
    reflex = VelocityReflex(LIMITS, ARM_JOINT_NAMES)
    inside = np.array(LIMITS) * (1.0 + REFLEX_MARGIN)
    assert reflex.check(inside, 0.0) is None                    # at the limit and its margin: inside
    assert reflex.check(-inside, 0.001) is None
    over = np.zeros(7)
    over[4] = -2.61 * (1.0 + REFLEX_MARGIN) - 0.001             # joint 5's limit is 2.61
    event = reflex.check(over, 0.002)
    assert event is not None and event.joint == "panda_joint5" and event.velocity == pytest.approx(-over[4])
    assert event.limit == 2.61 and event.time == 0.002 and "joint_velocity_violation" in event.message
    assert reflex.tripped and reflex.check(np.zeros(7), 0.003) is None and reflex.tripped


def test_a_nan_velocity_trips_it() -> None:
    reflex = VelocityReflex(LIMITS, ARM_JOINT_NAMES)
    event = reflex.check([0, 0, float("nan"), 0, 0, 0, 0], 1.0)
    assert event is not None and event.joint == "panda_joint3"


@pytest.mark.parametrize("limits", [LIMITS[:6], [1.0] * 6 + [0.0], [1.0] * 6 + [float("inf")]])
def test_bad_limits_are_refused(limits) -> None:
    with pytest.raises(FicInputError):
        VelocityReflex(limits, ARM_JOINT_NAMES)


def test_on_the_mujoco_arm_the_hold_brings_a_runaway_joint_to_rest() -> None:
    """A torque that keeps pushing joint 1 until the reflex trips, then the hold torque (what robot_node applies
    from then on): joint 1 never gets far past its limit and the arm comes to rest."""
    sim = PandaSimulation("free_space", 0)
    reflex = VelocityReflex(LIMITS, ARM_JOINT_NAMES)
    push = np.array([60.0, 0, 0, 0, 0, 0, 0])
    speeds = []
    for _ in range(1500):
        reflex.check(sim.joint_velocities, sim.time)
        sim.step(sim.hold_torque() if reflex.tripped else sim.hold_torque(np.zeros(7)) + push)
        speeds.append(np.abs(sim.joint_velocities).max())
    assert reflex.tripped and reflex.event.joint == "panda_joint1"
    tripped = int(round(reflex.event.time / 0.001))
    speeds = np.array(speeds)
    assert speeds.max() < LIMITS[0] * (1.0 + REFLEX_MARGIN) + 0.3, speeds.max()   # a step past it, then braked
    assert speeds[tripped + 200:].max() < LIMITS[0] and speeds[-1] < 0.05, speeds[-1]
