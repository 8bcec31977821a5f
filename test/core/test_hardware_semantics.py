"""Arm profiles, torque semantics, joint-name mapping, the stale-input ramp, wrench frames, device mapping."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from fic_core.arm_profile import FR3, PANDA, arm_profile, resolve_joint_names
from fic_core.errors import FicInputError
from fic_core.haptic_device_mapping import DeviceFrameMapping, GraspGain, device_command
from fic_core.joint_order import JointOrder
from fic_core.limits import PandaLimits
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.stale_input_ramp import StaleInputRamp
from fic_core.torque_semantics import TorqueSemantics
from fic_core.wrench_frame import WrenchFrame


def test_panda_profile_reproduces_the_limits_in_use(robot):
    """The Panda profile changes nothing for the simulated arm: the same limits as PandaLimits.from_robot."""
    assert PANDA.limits_for(robot.lower_position_limit, robot.upper_position_limit) == PandaLimits.from_robot(robot)


def test_fr3_limits_are_the_datasheet_cut_to_the_model(robot):
    limits = FR3.limits_for(robot.lower_position_limit, robot.upper_position_limit)
    assert limits.joint_velocity == (2.62, 2.62, 2.62, 2.62, 5.26, 4.18, 5.26)
    assert limits.tcp_speed == 3.0 and limits.torque_rate == 1000.0
    # joint 6: FR3 [0.5445, 4.5169] within the Panda URDF's [-0.0175, 3.7525] -> [0.5445, 3.7525]
    assert limits.joint_position_lower[5] == pytest.approx(0.5445)
    assert limits.joint_position_upper[5] == pytest.approx(robot.upper_position_limit[5])
    # joint 1: FR3's +-2.7437 is narrower than the Panda's +-2.8973
    assert limits.joint_position_upper[0] == pytest.approx(2.7437)
    assert all(lo >= m for lo, m in zip(limits.joint_position_lower, robot.lower_position_limit))
    assert all(hi <= m for hi, m in zip(limits.joint_position_upper, robot.upper_position_limit))


def test_joint_names_by_arm_prefix_or_list():
    assert resolve_joint_names(FR3) == tuple(f"fr3_joint{i}" for i in range(1, 8))
    assert resolve_joint_names(PANDA, joint_prefix="left_fr3") == tuple(f"left_fr3_joint{i}" for i in range(1, 8))
    names = [f"j{i}" for i in range(7)]
    assert resolve_joint_names(PANDA, names) == tuple(names)
    with pytest.raises(FicInputError, match="7 distinct"):
        resolve_joint_names(PANDA, ["a", "b"])
    with pytest.raises(FicInputError, match="arm_type"):
        arm_profile("ur5")


def test_joint_state_mapping_orders_by_name_and_names_both_sides_when_refusing():
    order = JointOrder(FR3.joint_names())
    shuffled = list(reversed(FR3.joint_names())) + ["fr3_finger_joint1"]
    q, _ = order.pick(shuffled, [float(i) for i in range(8)], [0.0] * 8)
    assert q.tolist() == [6.0, 5.0, 4.0, 3.0, 2.0, 1.0, 0.0]
    with pytest.raises(FicInputError) as refused:
        order.pick(list(PANDA.joint_names()), [0.0] * 7, [0.0] * 7)
    text = str(refused.value)
    assert "expected ['fr3_joint1'" in text and "received ['panda_joint1'" in text
    with pytest.raises(FicInputError, match="6 positions"):
        order.pick(list(FR3.joint_names()), [0.0] * 6, [0.0] * 7)


def test_gravity_left_to_the_robot_removes_exactly_g(robot):
    q = NOMINAL_CONFIGURATION + 0.1
    robot.update(q, np.zeros(7))
    gravity = robot.gravity
    tau = np.arange(7.0)
    assert np.allclose(TorqueSemantics(False).command(tau, gravity), tau)
    assert np.allclose(TorqueSemantics(True).command(tau, gravity), tau - gravity)
    assert np.allclose(TorqueSemantics(True).rest_command(gravity), 0.0)
    assert np.allclose(TorqueSemantics(False).rest_command(gravity), gravity)
    # Coriolis stays in the command: at a moving state the difference is G alone, not C qd + G.
    qd = np.full(7, 0.5)
    robot.update(q, qd)
    assert np.abs(robot.coriolis).max() > 1e-3
    assert np.allclose(tau - TorqueSemantics(True).command(tau, robot.gravity),
                       pin.computeGeneralizedGravity(robot.model, robot.model.createData(), q))


def test_stale_ramp_goes_linearly_to_rest_and_ends_on_fresh_input():
    ramp = StaleInputRamp(timeout=0.0625, ramp_time=0.5)  # binary-exact times
    assert not ramp.check(1.0, [10.0])           # nothing received yet: nothing to ramp from
    ramp.fresh(1.0)
    assert not ramp.check(1.0625, [10.0])        # exactly at the timeout: still fresh
    assert ramp.check(1.125, [10.0]) and ramp.stale
    assert not ramp.check(1.25, [10.0])          # reported once
    assert ramp.command(1.125, [2.0]) == pytest.approx([10.0])
    assert ramp.command(1.375, [2.0]) == pytest.approx([6.0])
    assert ramp.command(5.0, [2.0]) == pytest.approx([2.0])
    assert ramp.fresh(5.1) and not ramp.stale and ramp.engagements == 1
    with pytest.raises(FicInputError):
        ramp.command(5.2, [0.0])


def test_wrench_frame_refuses_other_frames_and_moves_the_moment():
    frame = WrenchFrame(("base", "fr3_link0"), sign=-1.0)
    force, torque = frame.at_tcp("base", [1.0, 2.0, 3.0], [0.1, 0.0, 0.0])
    assert force.tolist() == [-1.0, -2.0, -3.0] and torque.tolist() == [-0.1, 0.0, 0.0]
    with pytest.raises(FicInputError, match="fr3_hand_tcp"):
        frame.at_tcp("fr3_hand_tcp", [1.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    shifted = WrenchFrame(("base",), reference_offset=(0.0, 0.0, 0.1))  # K 10 cm beyond the TCP along its z
    _, moment = shifted.at_tcp("base", [1.0, 0.0, 0.0], [0.0, 0.0, 0.0], np.eye(3))
    assert moment == pytest.approx([0.0, 0.1, 0.0])  # (0, 0, 0.1) x (1, 0, 0)
    with pytest.raises(FicInputError):
        WrenchFrame(("base",), sign=0.5)


def test_device_mapping_round_trip_and_grasp_gain():
    quarter = (0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4))  # 90 deg about z
    mapping = DeviceFrameMapping(quarter, (0.01, 0.0, 0.0))
    assert mapping.position_to_master([0.02, 0.0, 0.0]) == pytest.approx([0.0, 0.01, 0.0])
    assert mapping.velocity_to_master([1.0, 0.0, 0.0]) == pytest.approx([0.0, 1.0, 0.0])
    assert mapping.force_to_device([0.0, 1.0, 0.0]) == pytest.approx([1.0, 0.0, 0.0])
    grasp = GraspGain(open_angle=0.5, closed_angle=0.1, max_gain=0.8)
    assert grasp.haptic_gain(0.6) == 0.0 and grasp.haptic_gain(0.0) == pytest.approx(0.8)
    assert grasp.haptic_gain(0.3) == pytest.approx(0.4)
    assert device_command(np.array([3.0, 4.0, 0.0]), 7, 2.5) == pytest.approx([1.5, 2.0, 0.0, 0, 0, 0, 0])
    with pytest.raises(FicInputError):
        device_command(np.zeros(3), 2, 1.0)
    with pytest.raises(FicInputError):
        GraspGain(open_angle=0.1, closed_angle=0.2)
