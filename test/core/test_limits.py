"""PandaLimits (datasheet + URDF), LimitFlag (same bits as the message), and the limit-violation check."""
from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from fic_core.errors import FicInputError
from fic_core.limits import LimitFlag, PandaLimits, limit_violations
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.robot_model import RobotModel

LIMIT_STATUS_MSG = Path(__file__).resolve().parents[2] / "fic_teleop_msgs" / "msg" / "LimitStatus.msg"


def test_datasheet_values(limits: PandaLimits, robot: RobotModel) -> None:
    assert limits.torque == (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
    assert limits.torque_rate == 1000.0
    assert limits.joint_velocity == (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61)
    assert limits.tcp_speed == 1.7
    np.testing.assert_array_equal(limits.lower_array, robot.lower_position_limit)
    np.testing.assert_array_equal(limits.upper_array, robot.upper_position_limit)


def test_limits_are_immutable(limits: PandaLimits) -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        limits.tcp_speed = 3.0  # type: ignore[misc]
    with pytest.raises(ValueError):
        limits.torque_array[0] = 1.0


def test_flag_values_match_the_limit_status_message() -> None:
    constants = dict(re.findall(r"^uint32 (\w+)=(\d+)", LIMIT_STATUS_MSG.read_text(), flags=re.MULTILINE))
    assert constants, "no constants parsed from LimitStatus.msg"
    for name, value in constants.items():
        assert LimitFlag[name].value == int(value)
    assert {flag.name for flag in LimitFlag if flag.value} == set(constants)


@pytest.mark.parametrize("overrides", [
    {"torque": (87.0, 87.0, 87.0, -1.0, 12.0, 12.0, 12.0)},
    {"torque_rate": 0.0},
    {"tcp_speed": float("nan")},
    {"joint_velocity": (1.0,) * 6},
    {"torque": (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 0.0)},
    {"joint_velocity": (0.0, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61)},
    {"tcp_speed": 0.0},
])
def test_invalid_limits_are_rejected(robot: RobotModel, overrides: dict) -> None:
    with pytest.raises(FicInputError):
        PandaLimits.from_robot(robot, **overrides)


@pytest.mark.parametrize("name", ["torque", "joint_velocity"])
def test_a_joint_limit_of_zero_is_refused_by_name_and_the_least_positive_one_taken(robot: RobotModel,
                                                                                  name: str) -> None:
    """Every limit must be > 0 (a zero limit would admit no torque or no motion at all on that joint)."""
    shipped = getattr(PandaLimits.from_robot(robot), name)
    with pytest.raises(FicInputError, match=f"^{name} limits must be > 0"):
        PandaLimits.from_robot(robot, **{name: shipped[:6] + (0.0,)})
    taken = PandaLimits.from_robot(robot, **{name: shipped[:6] + (5e-324,)})
    assert getattr(taken, name)[6] == 5e-324


def test_lower_above_upper_is_rejected() -> None:
    with pytest.raises(FicInputError, match="below"):
        PandaLimits(joint_position_lower=(0.0,) * 7, joint_position_upper=(0.0,) * 7)


def test_no_violation_inside_and_on_the_limits(limits: PandaLimits) -> None:
    torque = np.array(limits.torque)  # exactly on the torque limit
    previous = torque - 1.0  # exactly the allowed step at 1 ms
    qd = -np.array(limits.joint_velocity)
    q = np.array(limits.joint_position_upper)
    assert limit_violations(previous, torque, q, qd, 1.7, 0.001, limits) == LimitFlag.NONE
    assert limit_violations(None, np.zeros(7), NOMINAL_CONFIGURATION, np.zeros(7), 0.0, 0.001, limits) == \
        LimitFlag.NONE


def test_each_violation_is_flagged_alone(limits: PandaLimits) -> None:
    q0, qd0, tau0 = NOMINAL_CONFIGURATION.copy(), np.zeros(7), np.zeros(7)

    def check(expected: LimitFlag, *, previous=tau0, torque=tau0, q=q0, qd=qd0, speed=0.0) -> None:
        assert limit_violations(previous, torque, q, qd, speed, 0.001, limits) == expected

    tau = tau0.copy()
    tau[4] = 12.01
    check(LimitFlag.TORQUE | LimitFlag.TORQUE_RATE, torque=tau)
    check(LimitFlag.TORQUE, torque=tau, previous=tau - 0.5)
    tau = tau0.copy()
    tau[0] = 1.01
    check(LimitFlag.TORQUE_RATE, torque=tau)
    qd = qd0.copy()
    qd[1] = -2.2
    check(LimitFlag.JOINT_VELOCITY, qd=qd)
    q = q0.copy()
    q[5] = limits.joint_position_lower[5] - 1e-6
    check(LimitFlag.JOINT_POSITION, q=q)
    check(LimitFlag.TCP_SPEED, speed=1.71)
    # Without a previous command there is no torque rate to break.
    assert limit_violations(None, np.full(7, 10.0), q0, qd0, 0.0, 0.001, limits) == LimitFlag.NONE


def test_torque_rate_scales_with_dt(limits: PandaLimits) -> None:
    torque = np.full(7, 5.0)
    assert limit_violations(np.zeros(7), torque, NOMINAL_CONFIGURATION, np.zeros(7), 0.0, 0.001, limits) == \
        LimitFlag.TORQUE_RATE
    assert limit_violations(np.zeros(7), torque, NOMINAL_CONFIGURATION, np.zeros(7), 0.0, 0.01, limits) == \
        LimitFlag.NONE


def test_non_finite_inputs_are_rejected(limits: PandaLimits) -> None:
    bad = np.zeros(7)
    bad[2] = np.nan
    with pytest.raises(FicInputError, match="torque"):
        limit_violations(None, bad, NOMINAL_CONFIGURATION, np.zeros(7), 0.0, 0.001, limits)
    with pytest.raises(FicInputError, match="qd"):
        limit_violations(None, np.zeros(7), NOMINAL_CONFIGURATION, bad, 0.0, 0.001, limits)
    with pytest.raises(FicInputError, match="tcp_speed"):
        limit_violations(None, np.zeros(7), NOMINAL_CONFIGURATION, np.zeros(7), float("inf"), 0.001, limits)
    with pytest.raises(FicInputError, match="dt"):
        limit_violations(np.zeros(7), np.zeros(7), NOMINAL_CONFIGURATION, np.zeros(7), 0.0, 0.0, limits)
