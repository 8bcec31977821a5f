"""The master side outside ROS (fic_core.master_station, fic_core.operator_buttons): the handle velocity, the
feedback's staleness, the button edges and the parameter dispatch."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from config_values import config_values

from fic_core.errors import FicInputError
from fic_core.master_station import (
    GOAL_TRANSITION_SPEED,
    MASTER_PARAMETERS,
    READ_ONLY,
    Engagement,
    MasterParameters,
    MasterStation,
)
from fic_core.operator_buttons import ButtonEdges, OperatorButton
from fic_core.teleoperation import TeleoperationMode

DEFAULTS = config_values("master.yaml")  # the master node starts from these


def master(values: dict = DEFAULTS) -> MasterStation:
    """The station for these values, as the node builds it (MasterParameters, checked)."""
    return MasterStation(MasterParameters.from_values(values))


def test_the_parameters_are_one_typed_object_of_the_masters_table() -> None:
    """MasterParameters: one field a row of the table the node declares, each value checked against its row; a
    misspelt name is refused in one line naming the nearest row, as at the node's start."""
    parameters = MasterParameters.from_values(DEFAULTS)
    assert [field.name for field in dataclasses.fields(parameters)] == list(MASTER_PARAMETERS)
    assert set(MASTER_PARAMETERS) == set(DEFAULTS)                      # config/master.yaml gives every row
    assert parameters.stiffness == DEFAULTS["stiffness"] and parameters.mode == DEFAULTS["mode"]
    assert isinstance(parameters.replaced({"stiffness": 300}).stiffness, float)   # an integer is a number
    with pytest.raises(dataclasses.FrozenInstanceError):
        parameters.stiffness = 1.0
    with pytest.raises(FicInputError, match=r"^unknown master parameter 'stifness'; did you mean 'stiffness'\?$"):
        MasterParameters.from_values({**DEFAULTS, "stifness": 100.0})
    with pytest.raises(FicInputError, match=r"^master parameters missing: stiffness$"):
        MasterParameters.from_values({name: value for name, value in DEFAULTS.items() if name != "stiffness"})
    with pytest.raises(FicInputError, match=r"^stiffness must be in \[1, 5000\]"):
        MasterParameters.from_values({**DEFAULTS, "stiffness": 0.0})
    with pytest.raises(FicInputError, match="did you mean 'clutch'"):
        parameters.replaced({"clutc": True})


def test_edges_are_presses_not_held_buttons() -> None:
    edges = ButtonEdges()
    assert edges.pressed([1, 0, 0]) == {OperatorButton.TOGGLE_MODE}
    assert edges.pressed([1, 0, 0]) == set()
    assert edges.pressed([0, 1]) == {1}
    assert edges.pressed([0, 1, 1, 1]) == {2, 3}


def test_buttons_toggle_the_mode_and_step_the_gain() -> None:
    station = master()
    notices, changed = station.press([1, 1, 0])
    assert changed == ("mode", "haptic_gain") and station.integrator.mode == TeleoperationMode.VELOCITY
    assert station.law.haptic_gain == pytest.approx(0.6) and station.parameters.mode == 1
    station.press([0, 0, 0])
    for _ in range(10):
        station.press([0, 0, 1])   # HAPTIC_GAIN_DOWN
        station.press([0, 0, 0])
    assert station.law.haptic_gain == 0.0   # clamped at 0, said so
    assert any("clamped" in text for _, text in station.press([0, 0, 1])[0])


def test_velocity_by_differences_unless_a_twist_is_fresh() -> None:
    station = master()
    station.add_pose([0.0, 0.0, 0.0], (0, 0, 0, 1), 0.0)
    station.add_pose([0.001, 0.0, 0.0], (0, 0, 0, 1), 0.01)
    np.testing.assert_allclose(station.handle_velocity, [0.1, 0.0, 0.0])
    station.add_twist([0.0, 0.5, 0.0], 0.011)
    station.add_pose([0.002, 0.0, 0.0], (0, 0, 0, 1), 0.02)
    np.testing.assert_allclose(station.handle_velocity, [0.0, 0.5, 0.0])   # the device's own, while fresh
    station.add_pose([0.003, 0.0, 0.0], (0, 0, 0, 1), 0.5)                  # twist older than pose_timeout
    np.testing.assert_allclose(station.handle_velocity, [0.001 / 0.48, 0.0, 0.0])


def test_a_pose_received_at_the_same_time_as_the_last_keeps_the_differenced_velocity() -> None:
    """Two poses with one receipt time (a burst delivered together): no time has passed to difference over, so
    the handle velocity stays the last one measured, finite, and the newer pose is the handle's position."""
    station = master()
    station.add_pose([0.0, 0.0, 0.0], (0, 0, 0, 1), 0.0)
    station.add_pose([0.001, 0.0, 0.0], (0, 0, 0, 1), 0.01)
    station.add_pose([0.002, 0.0, 0.0], (0, 0, 0, 1), 0.01)
    np.testing.assert_allclose(station.handle_velocity, [0.1, 0.0, 0.0])
    np.testing.assert_array_equal(station.handle_position, [0.002, 0.0, 0.0])
    station.add_pose([0.003, 0.0, 0.0], (0, 0, 0, 1), 0.02)   # differenced from the newer pose of the burst
    np.testing.assert_allclose(station.handle_velocity, [0.1, 0.0, 0.0])


def test_the_network_tick_sends_the_handle_at_its_own_stamp() -> None:
    """x_M carried forward over the pose's age (device and network timers are not aligned), if that age is at
    most handle_extrapolation; x_d' is computed from it and the command carries the same x_M."""
    extrapolation = 0.01
    station = master({**DEFAULTS, "handle_extrapolation": extrapolation})   # offset mode, s_M = 1
    assert station.desired_offset(0.0) is None and station.handle_at(0.0) is None
    station.add_pose([0.1, 0.0, 0.0], (0, 0, 0, 1), 1.0)
    station.add_twist([0.2, -0.1, 0.0], 1.0)
    np.testing.assert_allclose(station.handle_at(1.003), [0.1006, -0.0003, 0.0])   # 3 ms at 0.2 / -0.1 m/s
    np.testing.assert_allclose(station.handle_at(1.0), [0.1, 0.0, 0.0])
    too_old = 1.0 + extrapolation + 1e-3
    np.testing.assert_allclose(station.handle_at(too_old), [0.1, 0.0, 0.0])   # an old pose is sent as it is
    np.testing.assert_allclose(station.handle_at(0.999), [0.1, 0.0, 0.0])     # a clock behind the pose: no guess
    reference = master()
    reference.add_pose([0.1006, -0.0003, 0.0], (0, 0, 0, 1), 1.003)
    np.testing.assert_allclose(station.desired_offset(1.003), reference.desired_offset(1.003))
    np.testing.assert_allclose(station.network_handle_position, [0.1006, -0.0003, 0.0])
    off = master()   # master.yaml: off, the pose as received
    off.add_pose([0.1, 0.0, 0.0], (0, 0, 0, 1), 1.0)
    off.add_twist([0.2, -0.1, 0.0], 1.0)
    np.testing.assert_allclose(off.handle_at(1.003), [0.1, 0.0, 0.0])
    off.configure({"handle_extrapolation": extrapolation})
    np.testing.assert_allclose(off.handle_at(1.003), [0.1006, -0.0003, 0.0])


def test_stale_feedback_is_rendered_as_zero_and_said_once() -> None:
    station = master({**DEFAULTS, "haptic_gain": 1.0, "stiffness": 1.0})
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
    station = master()
    law = station.law
    with pytest.raises(FicInputError):
        station.configure({"stiffness": 10.0, "max_force": 0.01})     # F_max below xi*K0*x_b
    with pytest.raises(FicInputError, match="fixed at start"):
        station.configure({"control_rate": 10.0})
    assert station.law is law and station.parameters.stiffness == DEFAULTS["stiffness"]
    notices = station.configure({"stiffness": 50.0, "workspace_scale": 2.0})
    assert station.law is not law and station.integrator.workspace_scale == 2.0 and "rebuilt" in notices[0][1]


# --- the operator's tools ----------------------------------------------------------------------------------------
def engaged_station(**overrides) -> MasterStation:
    """Offset mode, s_M = 2, a fresh F_R of 3 N along z, the handle still at x_M."""
    station = master({**DEFAULTS, "workspace_scale": 2.0, "haptic_gain": 0.5, **overrides})
    station.add_feedback([0.0, 0.0, 3.0], 0.0)
    return station


def move(station: MasterStation, position, now: float):
    """The handle at ``position`` at ``now`` (held still there), one control tick and one network tick."""
    station.add_pose(position, (0, 0, 0, 1), now)
    station.add_twist([0.0, 0.0, 0.0], now)
    force, notices = station.force(now)
    return force, station.desired_offset(now), notices


def test_the_clutch_holds_x_d_and_re_anchors_on_release() -> None:
    station = engaged_station()
    _, offset, _ = move(station, [0.01, 0.0, 0.0], 0.01)
    np.testing.assert_allclose(offset, [0.02, 0.0, 0.0])
    notices = station.configure({"clutch": True})
    assert station.engagement == Engagement.CLUTCHED and "holds still" in notices[0][1]
    for k, x in enumerate((0.0, -0.02, -0.03)):   # indexing: the handle brought back past the centre
        force, held, _ = move(station, [x, 0.005, 0.0], 0.02 + 0.01 * k)
        np.testing.assert_allclose(held, [0.02, 0.0, 0.0])
        # The handle feels its own FIC alone: F_R does not answer a motion the handle no longer makes.
        np.testing.assert_allclose(force, -station.law.attractor.profile.force(np.array([x, 0.005, 0.0])))
    station.configure({"clutch": False})
    assert station.engagement == Engagement.ENGAGED
    _, engaged, _ = move(station, [-0.03, 0.005, 0.0], 0.06)
    np.testing.assert_allclose(engaged, [0.02, 0.0, 0.0])               # no jump
    force, later, _ = move(station, [-0.01, 0.005, 0.0], 0.07)
    np.testing.assert_allclose(later, [0.02 + 2.0 * 0.02, 0.0, 0.0])    # s_M times the motion since the release
    assert force[2] == pytest.approx(1.5)                               # K_H F_R rendered again


def test_the_clutch_button_is_held_and_its_release_engages() -> None:
    station = engaged_station()
    move(station, [0.01, 0.0, 0.0], 0.01)
    notices, changed = station.press([0, 0, 0, 1])
    assert changed == ("clutch",) and station.parameters.clutch and station.integrator.held
    assert station.press([0, 0, 0, 1])[1] == ()          # still held: no edge
    assert station.press([1, 0, 0, 1])[1] == ("mode",)   # another button while it is held
    notices, changed = station.press([0, 0, 0, 0])
    assert changed == ("clutch",) and not station.parameters.clutch and not station.integrator.held


def test_homing_drives_the_handle_home_at_a_bounded_speed_then_engages() -> None:
    station = engaged_station()
    _, offset, _ = move(station, [0.01, 0.0, 0.0], 0.01)
    station.configure({"homing": True})
    assert station.engagement == Engagement.HOMING and station.parameters.homing
    # A free handle (0.5 kg, 2 N s/m) 6 cm out, the station's force held over each 4 ms tick, integrated at 1 ms.
    position, velocity, now, speeds, offsets = np.array([0.06, -0.02, 0.0]), np.zeros(3), 0.02, [], []
    while station.engagement == Engagement.HOMING and now < 5.0:
        station.add_pose(position, (0, 0, 0, 1), now)
        station.add_twist(velocity, now)
        force, _ = station.force(now)
        offsets.append(station.desired_offset(now))   # the last one: engaged at the handle's position then
        engaged_at = position
        for _ in range(4):
            velocity = velocity + 0.001 * (force - 2.0 * velocity) / 0.5
            position = position + 0.001 * velocity
            speeds.append(np.linalg.norm(velocity))
        now += 0.004
    assert station.engagement == Engagement.ENGAGED and not station.parameters.homing
    assert max(speeds) <= DEFAULTS["homing_speed"] and np.linalg.norm(position) < 2 * DEFAULTS["homing_tolerance"]
    for held in offsets:
        np.testing.assert_allclose(held, offset)        # x_d' still until homed, and engaged without a jump
    _, engaged, _ = move(station, position, now)
    np.testing.assert_allclose(engaged, offset + 2.0 * (position - engaged_at))   # then the handle drives it


def test_the_force_scale_is_set_live_within_the_loop_gain_bound() -> None:
    station = engaged_station(workspace_scale=1.0)
    station.configure({"force_scale": 2.0})             # 2 x 1 x 0.5 = 1: allowed
    force, _, _ = move(station, [0.0, 0.0, 0.0], 0.01)
    assert force[2] == pytest.approx(3.0) and station.loop_gain() == pytest.approx(1.0)
    for change in ({"force_scale": 2.5}, {"workspace_scale": 1.5}, {"haptic_gain": 0.6}):
        with pytest.raises(FicInputError, match="above the loop-gain bound 1"):
            station.configure(change)
    assert station.law.force_scale == 2.0 and station.integrator.workspace_scale == 1.0   # nothing applied
    # Both at once, finer motion with a larger force scale: allowed.
    station.configure({"workspace_scale": 0.25, "force_scale": 4.0, "haptic_gain": 1.0})
    assert station.loop_gain() == pytest.approx(1.0)
    # A K_H from a button is clamped to what the bound allows, said in one notice.
    station.configure({"haptic_gain": 0.5})
    station.configure({"workspace_scale": 0.5})         # 4 x 0.5 x 0.5 = 1
    notices, _ = station.press([0, 1, 0, 0])
    assert station.law.haptic_gain == pytest.approx(0.5) and "may not exceed 1" in notices[0][1]
    with pytest.raises(FicInputError):
        master({**DEFAULTS, "force_scale": 3.0})   # at start too: 3 x 1 x 0.5


def test_a_plane_fixture_guides_x_d_onto_it_while_engaged() -> None:
    station = engaged_station(haptic_gain=0.0)
    move(station, [0.0, 0.0, 0.0], 0.0)
    station.configure({"guidance_fixture": "plane", "guidance_point": [0.0, 0.0, 0.004],
                       "guidance_direction": [0.0, 0.0, 1.0]})
    handle = np.array([0.01, 0.0, 0.005])   # x_d' = s_M x_M = (0.02, 0, 0.01): 6 mm above the plane
    force, offset, _ = move(station, handle, 0.01)
    own = -station.law.attractor.profile.force(handle)
    guidance = DEFAULTS["guidance_stiffness"] * np.array([0.0, 0.0, -0.006])
    np.testing.assert_allclose(force, own + guidance)
    np.testing.assert_allclose(station.guidance_force, guidance)
    np.testing.assert_allclose(station.fixture_goal(), [0.02, 0.0, 0.004])
    for k in range(2, 8):   # switched on at x_d' = 0 (4 mm off the plane): its jump given back at 0.1 m/s
        _, offset, _ = move(station, handle, 0.01 * k)
    np.testing.assert_allclose(offset, [0.02, 0.0, 0.004])   # the replica's goal is the projection
    np.testing.assert_allclose(station.integrator.desired_offset, [0.02, 0.0, 0.01])   # the handle's x_d' is not
    # Not rendered while the clutch is held; gone with the fixture.
    station.configure({"clutch": True})
    np.testing.assert_allclose(move(station, handle, 0.08)[0], own)
    station.configure({"clutch": False, "guidance_fixture": "none"})
    np.testing.assert_allclose(move(station, handle, 0.09)[0], own)
    assert station.fixture_goal() is None
    # A fixture that cannot be is refused, and the one in place stays.
    station.configure({"guidance_fixture": "line", "guidance_direction": [1.0, 0.0, 0.0]})
    with pytest.raises(FicInputError, match="guidance_direction must not be zero"):
        station.configure({"guidance_direction": [0.0, 0.0, 0.0]})
    with pytest.raises(FicInputError, match="guidance_fixture must be one of"):
        station.configure({"guidance_fixture": "sphere"})
    assert station.fixture.kind.name == "LINE" and station.parameters.guidance_fixture == "line"


def test_switching_a_fixture_moves_the_sent_goal_at_a_bounded_speed_never_in_a_jump() -> None:
    station = engaged_station(haptic_gain=0.0)
    handle = np.array([0.01, 0.0, 0.015])   # x_d' = (0.02, 0, 0.03)
    _, offset, _ = move(station, handle, 0.0)
    np.testing.assert_allclose(offset, [0.02, 0.0, 0.03])
    station.configure({"guidance_fixture": "plane", "guidance_point": [0.0, 0.0, 0.0],
                       "guidance_direction": [0.0, 0.0, 1.0]})
    sent = [offset]
    for k in range(1, 60):   # 10 ms network ticks: 30 mm at 0.1 m/s take 0.3 s
        sent.append(move(station, handle, 0.01 * k)[1])
    steps = np.linalg.norm(np.diff(sent, axis=0), axis=1)
    assert steps.max() <= GOAL_TRANSITION_SPEED * 0.01 + 1e-12
    np.testing.assert_allclose(sent[-1], [0.02, 0.0, 0.0], atol=1e-12)   # on the plane once the jump is given back
    station.configure({"guidance_fixture": "none"})
    back = [move(station, handle, 0.59 + 0.01 * k)[1] for k in range(1, 40)]
    assert np.linalg.norm(np.diff([sent[-1], *back], axis=0), axis=1).max() <= GOAL_TRANSITION_SPEED * 0.01 + 1e-12
    np.testing.assert_allclose(back[-1], [0.02, 0.0, 0.03], atol=1e-12)


def test_the_teleoperation_command_carries_x_d_prime_with_the_mode_gains_and_handle_of_its_tick() -> None:
    station = master({**DEFAULTS, "handle_extrapolation": 0.0})
    assert station.teleoperation_command(0.0) is None   # no handle pose yet
    station.add_pose([0.01, -0.02, 0.03], (0.0, 0.0, 0.0, 1.0), 0.0)
    sample = station.teleoperation_command(0.01)
    assert sample is not None and sample.mode == int(station.mode) == int(TeleoperationMode(DEFAULTS["mode"]))
    assert sample.haptic_gain == station.law.haptic_gain and sample.workspace_scale == DEFAULTS["workspace_scale"]
    assert sample.velocity_gain == DEFAULTS["velocity_gain"]
    np.testing.assert_array_equal(sample.handle_position, [0.01, -0.02, 0.03])
    np.testing.assert_array_equal(sample.desired_offset, station.integrated_offset)   # no fixture: as integrated
    sample.handle_position[0] = 1.0   # the sample's own copy
    assert station.network_handle_position[0] == 0.01


# --- freshness, counts and what the station says ---------------------------------------------------------------
def timed_station() -> MasterStation:
    """Timeouts on binary fractions (pose 1/8 s, F_R 1/4 s), so that an age of exactly a timeout is exact."""
    return master({**DEFAULTS, "pose_timeout": 0.125, "feedback_timeout": 0.25, "haptic_gain": 1.0})


def test_a_pose_or_f_r_exactly_a_timeout_old_is_still_fresh_and_one_a_hair_older_is_not() -> None:
    """pose_timeout and feedback_timeout are the longest an input may be used: at that age the handle's Eq. 3
    force (its FIC plus K_H F_R) is rendered; past it, zero, and F_R's staleness said once."""
    station = timed_station()
    station.add_pose([0.0, 0.0, 0.0], (0, 0, 0, 1), 1.0)
    station.add_feedback([2.0, 0.0, 0.0], 1.0)
    force, notices = station.force(1.125)
    np.testing.assert_allclose(force, [2.0, 0.0, 0.0], atol=1e-12)
    assert notices == []
    assert not station.pose_stale(1.125) and station.pose_stale(float(np.nextafter(1.125, 2.0)))
    station.add_pose([0.0, 0.0, 0.0], (0, 0, 0, 1), 1.25)
    np.testing.assert_allclose(station.feedback_force(1.25)[0], [2.0, 0.0, 0.0])
    force, notices = station.force(float(np.nextafter(1.25, 2.0)))
    np.testing.assert_allclose(force, 0.0, atol=1e-12)
    assert notices == [("warning", "/master/feedback_wrench is stale (0.25 s old): rendering F_R = 0")]


def test_a_twist_exactly_pose_timeout_old_is_still_the_velocity() -> None:
    station = timed_station()
    station.add_pose([0.0, 0.0, 0.0], (0, 0, 0, 1), 1.0)
    station.add_twist([0.0, 0.3, 0.0], 1.0)
    station.add_pose([0.01, 0.0, 0.0], (0, 0, 0, 1), 1.125)
    np.testing.assert_array_equal(station.handle_velocity, [0.0, 0.3, 0.0])
    station.add_pose([0.02, 0.0, 0.0], (0, 0, 0, 1), 1.25)                  # now 0.25 s old: differences
    np.testing.assert_allclose(station.handle_velocity, [0.08, 0.0, 0.0])


def test_a_stale_pose_counts_a_wrench_command_but_no_evaluation_of_eq_3() -> None:
    """wrench_commands counts every device command, the zero of a stale pose too; law_evaluations (what the
    exchanged-energy observer books) only those that evaluated Eq. 3."""
    station = timed_station()
    assert station.force(0.0) == (None, [])   # before the first pose: no command at all
    station.add_pose([0.0, 0.0, 0.0], (0, 0, 0, 1), 0.0)
    station.force(0.1)
    station.force(0.2)   # stale
    station.force(0.3)
    assert (station.wrench_count, station.law_evaluations) == (3, 1)
    problems, values = station.diagnostics(0.3)
    assert "/haptic/pose stale" in problems and values["wrench_commands"] == "3"


def test_the_diagnostics_say_what_is_missing_and_the_stations_figures() -> None:
    station = timed_station()
    problems, values = station.diagnostics(0.0)
    assert problems == ["no /haptic/pose yet"] and values["feedback_age_s"] == "inf"
    station.add_pose([0.01, 0.0, 0.0], (0, 0, 0, 1), 0.0)
    station.force(0.01)   # F_R never received: stale, said
    problems, values = station.diagnostics(0.01)
    assert problems == ["/master/feedback_wrench stale (F_R = 0)"]
    station.add_feedback([0.0, 0.0, 1.0], 0.02)
    problems, values = station.diagnostics(0.07)
    assert problems == [] and values["feedback_age_s"] == "0.050"
    assert values["mode"] == "OFFSET" and values["haptic_gain"] == "1.000" and values["engagement"] == "ENGAGED"
    assert values["loop_gain"] == "1.000" and values["guidance_fixture"] == "none"
    assert values["desired_offset"] == "0.0000 0.0000 0.0000" and values["device_force_saturated_ticks"] == "0"


# --- homing's limits and ends ----------------------------------------------------------------------------------
def test_the_homing_force_is_held_to_the_device_limit_and_counted() -> None:
    """Homing obeys max_device_force as Eq. 3's force does: a handle 30 cm out, moving away at 2 m/s, asks for more
    than a 1 N device; the command is that norm, along the homing force, and counted saturated."""
    station = master({**DEFAULTS, "max_device_force": 1.0, "homing": True})
    station.add_pose([0.3, 0.0, 0.0], (0, 0, 0, 1), 0.0)
    station.add_twist([2.0, 0.0, 0.0], 0.0)
    asked = station.homing.force(station.handle_position, station.handle_velocity)
    assert np.linalg.norm(asked) > 1.0
    force, _ = station.force(0.0)
    assert np.linalg.norm(force) == pytest.approx(1.0)
    np.testing.assert_allclose(force / np.linalg.norm(force), asked / np.linalg.norm(asked))
    assert station.saturated_count == 1
    station.configure({"max_device_force": 0.0})   # 0: no limit
    np.testing.assert_allclose(station.force(0.0)[0], asked)
    assert station.saturated_count == 1


def test_homing_that_ends_with_the_clutch_held_leaves_the_handle_clutched() -> None:
    station = master({**DEFAULTS, "homing": True, "clutch": True})
    station.add_pose([0.0005, 0.0, 0.0], (0, 0, 0, 1), 0.0)   # within the 2 mm tolerance
    _, notices = station.force(0.0)
    assert station.engagement == Engagement.CLUTCHED and station.integrator.held and not station.parameters.homing
    assert notices == [("info", "handle homed (0.5 mm from the centre): the clutch is still held")]


def test_homing_stopped_early_engages_the_handle_where_it_is_and_restarts_its_fic() -> None:
    station = master({**DEFAULTS, "homing": True})
    station.add_pose([0.03, 0.0, 0.0], (0, 0, 0, 1), 0.0)
    station.force(0.0)
    assert station.engagement == Engagement.HOMING and station.configure({"homing": True}) == []
    law = station.law
    notices = station.configure({"homing": False})
    assert notices == [("warning", "homing stopped before the handle was home: engaged where it is")]
    assert station.engagement == Engagement.ENGAGED and not station.integrator.held and station.law is law
    assert station.configure({"homing": False}) == []   # not homing: nothing to stop
    before = station.desired_offset(0.01)
    station.add_pose([0.04, 0.0, 0.0], (0, 0, 0, 1), 0.02)
    np.testing.assert_allclose(station.desired_offset(0.02) - before, [0.01, 0.0, 0.0])   # s_M = 1 from here


# --- the parameter dispatch --------------------------------------------------------------------------------------
def test_configure_refuses_a_non_finite_number_and_leaves_other_nodes_names_alone() -> None:
    station = master()
    for bad in (float("nan"), float("inf")):
        with pytest.raises(FicInputError, match="pose_timeout must be finite"):
            station.configure({"pose_timeout": bad})
    assert station.configure({"use_sim_time": True}) == [] and station.parameters == master().parameters


def test_configure_applies_the_timeouts_the_device_limit_the_mode_and_the_deadband() -> None:
    station = master()
    notices = station.configure({"pose_timeout": 0.25, "feedback_timeout": 2.0, "max_device_force": 5.0,
                                 "mode": 1, "velocity_deadband": 0.01, "velocity_gain": 4.0})
    assert (station.pose_timeout, station.feedback_timeout, station.law.max_device_force) == (0.25, 2.0, 5.0)
    assert station.integrator.mode == TeleoperationMode.VELOCITY and station.parameters.mode == 1
    assert notices == [("info", "teleoperation mode: VELOCITY (parameter)")]
    assert station.configure({"mode": 1}) == []   # no change, nothing said
    assert (station.integrator.velocity_deadband, station.integrator.velocity_gain) == (0.01, 4.0)
    assert station.parameters.pose_timeout == 0.25 and station.parameters.max_device_force == 5.0


def test_a_haptic_gain_above_one_from_a_parameter_is_clamped_to_one_and_said() -> None:
    station = master()
    notices = station.configure({"haptic_gain": 3.0})
    assert station.law.haptic_gain == 1.0 and station.parameters.haptic_gain == 1.0
    assert notices == [("warning", "haptic_gain 3.0 from parameter clamped to 1.0")]
    with pytest.raises(FicInputError, match="haptic_gain"):
        station.set_haptic_gain(float("nan"), "topic")
    assert station.law.haptic_gain == 1.0 and station.set_haptic_gain(0.25, "topic") == []


# --- the velocity mode's clock -------------------------------------------------------------------------------------
def test_velocity_mode_integrates_over_the_network_ticks_own_intervals() -> None:
    """x_d' += k_v x_M dt with dt the time since the last network tick (k_v = 2 /s, x_M 5 cm out of the 5 mm
    dead-band: 10 cm/s); a tick whose clock is behind the last adds nothing."""
    station = master({**DEFAULTS, "mode": 1})
    station.add_pose([0.05, 0.0, 0.0], (0, 0, 0, 1), 0.0)
    np.testing.assert_allclose(station.desired_offset(1.0), 0.0)            # the first tick: no interval yet
    np.testing.assert_allclose(station.desired_offset(1.5), [0.045 * 2.0 * 0.5, 0.0, 0.0])
    np.testing.assert_allclose(station.desired_offset(1.2), [0.045, 0.0, 0.0])   # back in time: dt = 0
    np.testing.assert_allclose(station.desired_offset(1.3), [0.045 + 0.009, 0.0, 0.0])


def test_the_handle_fic_starts_afresh_once_homed() -> None:
    """Eq. 2's attractor is not evaluated while homing, so the phase and latched peak it held when homing began
    describe a motion long gone: once homed it starts again as a new one does (divergence, nothing latched)."""
    station = engaged_station()
    for now, x, speed in ((0.0, 0.03, 0.3), (0.004, 0.029, -0.3)):   # out to 3 cm, then coming back
        station.add_pose([x, 0.0, 0.0], (0, 0, 0, 1), now)
        station.add_twist([speed, 0.0, 0.0], now)
        station.force(now)
    assert station.law.attractor.phase[0] == 1 and abs(station.law.attractor.latched_max_error[0]) > 0.02
    station.configure({"homing": True})
    station.add_pose([0.001, 0.0, 0.0], (0, 0, 0, 1), 0.1)
    station.add_twist([0.0, 0.0, 0.0], 0.1)
    station.force(0.1)   # within the 2 mm tolerance: homed
    assert station.engagement == Engagement.ENGAGED
    np.testing.assert_array_equal(station.law.attractor.phase, 0)
    np.testing.assert_array_equal(station.law.attractor.latched_max_error, 0.0)


def test_each_tick_whose_eq_3_force_the_device_limit_cut_is_counted() -> None:
    """K_H F_R of 30 N against a 20 N device: every such tick is one more saturated tick in the diagnostics, and a
    tick within the limit adds none."""
    station = master({**DEFAULTS, "haptic_gain": 1.0, "max_device_force": 20.0})
    station.add_pose([0.0, 0.0, 0.0], (0, 0, 0, 1), 0.0)
    station.add_feedback([30.0, 0.0, 0.0], 0.0)
    for now in (0.004, 0.008):
        force, _ = station.force(now)
        assert np.linalg.norm(force) == pytest.approx(20.0)
    station.add_feedback([3.0, 0.0, 0.0], 0.01)
    station.force(0.012)
    assert station.saturated_count == 2 and station.diagnostics(0.012)[1]["device_force_saturated_ticks"] == "2"


def test_a_guidance_fixture_without_damping_is_its_spring_alone() -> None:
    """B = 0 is a valid fixture (a spring onto the plane, whatever the handle's velocity across it): the station
    takes it, and the guidance force is K times the distance to the plane for a handle moving across it."""
    station = engaged_station(haptic_gain=0.0)
    station.configure({"guidance_fixture": "plane", "guidance_point": [0.0, 0.0, 0.0],
                       "guidance_direction": [0.0, 0.0, 1.0], "guidance_damping": 0.0})
    station.add_pose([0.0, 0.0, 0.005], (0, 0, 0, 1), 0.0)   # x_d' = s_M x_M: 10 mm above the plane
    station.add_twist([0.0, 0.0, 0.3], 0.0)                  # moving away from it
    station.force(0.0)
    np.testing.assert_allclose(station.guidance_force, [0.0, 0.0, -DEFAULTS["guidance_stiffness"] * 0.01])


def test_the_parameters_fixed_at_start_are_the_tables_read_only_rows_and_each_is_refused_live() -> None:
    """The rates (timers are made from them), the frame, the channel port's and the exchanged-energy observer's rows
    are fixed at start: the node declares each read-only (its descriptor refuses a change), and the station refuses
    a live change of every one of them too (the two lists are one)."""
    assert set(READ_ONLY) == {name for name, row in MASTER_PARAMETERS.items() if row.read_only}
    assert {"channel_passivity_control", "channel_energy_window", "exchanged_energy_observer"} <= set(READ_ONLY)
    station = master()
    for name in READ_ONLY:
        with pytest.raises(FicInputError, match=f"^{name} is fixed at start$"):
            station.configure({name: DEFAULTS[name]})
