"""The master side outside ROS (fic_core.master_station, fic_core.operator_buttons): the handle velocity, the
feedback's staleness, the button edges and the parameter dispatch."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.errors import FicInputError
from fic_core.master_station import MasterStation
from fic_core.operator_buttons import ButtonEdges, OperatorButton
from fic_core.teleoperation import TeleoperationMode

from config_values import config_values

DEFAULTS = config_values("master.yaml")  # the master node starts from these


def test_edges_are_presses_not_held_buttons() -> None:
    edges = ButtonEdges()
    assert edges.pressed([1, 0, 0]) == {OperatorButton.TOGGLE_MODE}
    assert edges.pressed([1, 0, 0]) == set()
    assert edges.pressed([0, 1]) == {1}
    assert edges.pressed([0, 1, 1, 1]) == {2, 3}


def test_buttons_toggle_the_mode_and_step_the_gain() -> None:
    station = MasterStation(DEFAULTS)
    notices, changed = station.press([1, 1, 0])
    assert changed == ("mode", "haptic_gain") and station.integrator.mode == TeleoperationMode.VELOCITY
    assert station.law.haptic_gain == pytest.approx(0.6) and station.parameters["mode"] == 1
    station.press([0, 0, 0])
    for _ in range(10):
        station.press([0, 0, 1])   # HAPTIC_GAIN_DOWN
        station.press([0, 0, 0])
    assert station.law.haptic_gain == 0.0   # clamped at 0, said so
    assert any("clamped" in text for _, text in station.press([0, 0, 1])[0])


def test_velocity_by_differences_unless_a_twist_is_fresh() -> None:
    station = MasterStation(DEFAULTS)
    station.add_pose([0.0, 0.0, 0.0], (0, 0, 0, 1), 0.0)
    station.add_pose([0.001, 0.0, 0.0], (0, 0, 0, 1), 0.01)
    np.testing.assert_allclose(station.handle_velocity, [0.1, 0.0, 0.0])
    station.add_twist([0.0, 0.5, 0.0], 0.011)
    station.add_pose([0.002, 0.0, 0.0], (0, 0, 0, 1), 0.02)
    np.testing.assert_allclose(station.handle_velocity, [0.0, 0.5, 0.0])   # the device's own, while fresh
    station.add_pose([0.003, 0.0, 0.0], (0, 0, 0, 1), 0.5)                  # twist older than pose_timeout
    np.testing.assert_allclose(station.handle_velocity, [0.001 / 0.48, 0.0, 0.0])


def test_the_network_tick_sends_the_handle_at_its_own_stamp() -> None:
    """x_M carried forward over the pose's age (device and network timers are not aligned), if that age is at
    most handle_extrapolation; x_d' is computed from it and the command carries the same x_M."""
    extrapolation = 0.01
    station = MasterStation({**DEFAULTS, "handle_extrapolation": extrapolation})   # offset mode, s_M = 1
    assert station.desired_offset(0.0) is None and station.handle_at(0.0) is None
    station.add_pose([0.1, 0.0, 0.0], (0, 0, 0, 1), 1.0)
    station.add_twist([0.2, -0.1, 0.0], 1.0)
    np.testing.assert_allclose(station.handle_at(1.003), [0.1006, -0.0003, 0.0])   # 3 ms at 0.2 / -0.1 m/s
    np.testing.assert_allclose(station.handle_at(1.0), [0.1, 0.0, 0.0])
    too_old = 1.0 + extrapolation + 1e-3
    np.testing.assert_allclose(station.handle_at(too_old), [0.1, 0.0, 0.0])   # an old pose is sent as it is
    np.testing.assert_allclose(station.handle_at(0.999), [0.1, 0.0, 0.0])     # a clock behind the pose: no guess
    reference = MasterStation(DEFAULTS)
    reference.add_pose([0.1006, -0.0003, 0.0], (0, 0, 0, 1), 1.003)
    np.testing.assert_allclose(station.desired_offset(1.003), reference.desired_offset(1.003))
    np.testing.assert_allclose(station.network_handle_position, [0.1006, -0.0003, 0.0])
    off = MasterStation(DEFAULTS)   # master.yaml: off, the pose as received
    off.add_pose([0.1, 0.0, 0.0], (0, 0, 0, 1), 1.0)
    off.add_twist([0.2, -0.1, 0.0], 1.0)
    np.testing.assert_allclose(off.handle_at(1.003), [0.1, 0.0, 0.0])
    off.configure({"handle_extrapolation": extrapolation})
    np.testing.assert_allclose(off.handle_at(1.003), [0.1006, -0.0003, 0.0])


def test_stale_feedback_is_rendered_as_zero_and_said_once() -> None:
    station = MasterStation({**DEFAULTS, "haptic_gain": 1.0, "stiffness": 1.0})
    station.add_pose([0.0, 0.0, 0.0], (0, 0, 0, 1), 0.0)
    station.add_feedback([3.0, 0.0, 0.0], 0.0)
    force, notices = station.force(0.05)
    np.testing.assert_allclose(force, [3.0, 0.0, 0.0], atol=1e-9)
    assert not notices
    station.add_pose([0.0, 0.0, 0.0], (0, 0, 0, 1), 0.6)
    force, notices = station.force(0.6)
    np.testing.assert_allclose(force, 0.0, atol=1e-9)
    assert len(notices) == 1 and station.force(0.6)[1] == []
    assert station.add_feedback([1.0, 0.0, 0.0], 0.7) and not station.feedback_stale
    force, notices = station.force(1.0)   # the pose is stale now: zero force
    np.testing.assert_allclose(force, 0.0)
    assert notices[0][0] == "repeated_warning"


def test_a_bad_parameter_changes_nothing() -> None:
    station = MasterStation(DEFAULTS)
    law = station.law
    with pytest.raises(FicInputError):
        station.configure({"stiffness": 10.0, "max_force": 0.01})     # F_max below xi*K0*x_b
    with pytest.raises(FicInputError, match="fixed at start"):
        station.configure({"control_rate": 10.0})
    assert station.law is law and station.parameters["stiffness"] == DEFAULTS["stiffness"]
    notices = station.configure({"stiffness": 50.0, "workspace_scale": 2.0})
    assert station.law is not law and station.integrator.workspace_scale == 2.0 and "rebuilt" in notices[0][1]
