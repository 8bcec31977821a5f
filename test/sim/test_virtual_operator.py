"""The virtual operator (sim_bridge/device/virtual_operator.py) and the scene scripts
(sim_bridge/device/operator_scripts.py)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fic_core.errors import FicInputError
from sim_bridge.device.haptic_device import HapticDevice, HapticDeviceParameters
from sim_bridge.device.operator_scripts import (
    GENERATORS,
    SHAPE_SORTING_DEFAULTS,
    shape_sorting_script,
    superimposition_script,
)
from sim_bridge.device.virtual_operator import (
    BUTTON_HAPTIC_GAIN_UP,
    BUTTON_TOGGLE_MODE,
    Hand,
    HandParameters,
    JoyTarget,
    OperatorScript,
    ScriptedOperator,
    ScriptEvent,
    Waypoint,
    load_script,
    script_from_mapping,
    script_to_mapping,
)

CONFIG = Path(__file__).resolve().parents[2] / "config" / "operator_scripts"
HALF_EXTENTS = np.array(HapticDeviceParameters().half_extents)


def simulate(target_of_time, duration: float, master_stiffness: float = 0.0, hand: Hand | None = None,
             dt: float = 0.002):
    """Hand + device closed loop at the node's 500 Hz, optionally against a master spring toward the origin."""
    hand = hand or Hand()
    device = HapticDevice()
    positions = []
    for step in range(int(round(duration / dt))):
        hand.update(target_of_time(step * dt), device.position, dt)
        device.step(-master_stiffness * device.position, hand.force, dt)
        positions.append(device.position.copy())
    return np.array(positions)


def test_the_hand_pulls_the_handle_to_a_fixed_target_without_much_overshoot():
    target = np.array([0.05, -0.03, 0.02])
    positions = simulate(lambda t: target, 3.0, hand=Hand(HandParameters(correction_rate=0.0)))
    assert positions[-1] == pytest.approx(target, abs=1e-4)
    overshoot = np.max(positions[:, 0]) - target[0]
    assert overshoot < 0.1 * target[0]            # damping ratio about 0.7: a few percent


def test_a_pure_spring_hand_falls_short_against_the_master_spring_and_the_lean_in_fixes_it():
    target = np.array([0.05, 0.0, 0.0])
    short = simulate(lambda t: target, 4.0, master_stiffness=200.0,
                     hand=Hand(HandParameters(correction_rate=0.0)))
    assert short[-1][0] == pytest.approx(0.05 * 300.0 / 500.0, abs=1e-4)
    leaned = simulate(lambda t: target, 6.0, master_stiffness=200.0)
    assert leaned[-1][0] == pytest.approx(0.05, abs=5e-4)


def test_the_lean_in_and_the_hand_force_are_bounded():
    hand = Hand()
    for _ in range(10_000):                           # the handle is stuck at the origin for 20 s
        hand.update([0.09, 0.0, 0.0], np.zeros(3), 0.002)
    assert np.linalg.norm(hand.correction) == pytest.approx(hand.parameters.max_correction)
    assert np.linalg.norm(hand.force(np.zeros(3), np.zeros(3))) == pytest.approx(hand.parameters.max_force)


def test_smooth_interpolation_passes_the_waypoints_at_rest_and_keeps_the_linear_area():
    script = OperatorScript("s", (Waypoint(0.0, np.zeros(3)), Waypoint(1.0, np.array([0.1, 0.0, 0.0])),
                                  Waypoint(3.0, np.array([0.1, 0.05, 0.0]))))
    assert script.target(-1.0) == pytest.approx([0.0, 0.0, 0.0])
    assert script.target(1.0) == pytest.approx([0.1, 0.0, 0.0])
    assert script.target(9.0) == pytest.approx([0.1, 0.05, 0.0])
    assert script.target(0.5) == pytest.approx([0.05, 0.0, 0.0])
    h = 1e-4
    assert np.linalg.norm(script.target(1.0 + h) - script.target(1.0 - h)) / (2 * h) < 1e-3   # at rest
    times = np.linspace(0.0, 1.0, 20001)
    area = np.trapezoid([script.target(t)[0] for t in times], times)
    assert area == pytest.approx(0.05, rel=1e-4)
    linear = OperatorScript("l", script.waypoints, interpolation="linear")
    assert linear.target(0.25) == pytest.approx([0.025, 0.0, 0.0])


def test_scripted_operator_emits_each_event_once_in_order():
    script = OperatorScript("e", (Waypoint(0.0, np.zeros(3)),),
                            (ScriptEvent(1.0, BUTTON_TOGGLE_MODE), ScriptEvent(1.0, BUTTON_HAPTIC_GAIN_UP),
                             ScriptEvent(2.5, BUTTON_TOGGLE_MODE)))
    operator = ScriptedOperator(script)
    assert operator.poll_events(0.9) == []
    assert [e.button for e in operator.poll_events(1.0)] == [BUTTON_TOGGLE_MODE, BUTTON_HAPTIC_GAIN_UP]
    assert operator.poll_events(2.0) == []
    assert not operator.finished(2.0)
    assert [e.time for e in operator.poll_events(10.0)] == [2.5]
    assert operator.poll_events(11.0) == [] and operator.finished(11.0)


def test_joy_target_moves_at_the_axis_velocity_and_stays_in_the_workspace():
    joy = JoyTarget(HALF_EXTENTS, max_speed=0.1, dead_zone=0.05, margin=0.005)
    for _ in range(50):
        joy.update([1.0, -0.5, 0.02], 0.01)          # 0.5 s; z inside the dead zone
    assert joy.target == pytest.approx([0.05, -0.025, 0.0])
    for _ in range(1000):
        joy.update([1.0, -1.0, 1.0], 0.01)
    assert joy.target == pytest.approx(HALF_EXTENTS * [1, -1, 1] - np.array([0.005, -0.005, 0.005]))
    assert joy.update([0.0], 0.1) == pytest.approx(joy.target)    # short axes arrays are fine
    with pytest.raises(FicInputError, match="axes"):
        joy.update([math.nan, 0.0, 0.0], 0.01)


@pytest.mark.parametrize("scene", sorted(GENERATORS))
def test_checked_in_scripts_load_stay_in_the_workspace_and_match_their_generator(scene):
    script = load_script(CONFIG / f"{scene}.yaml")
    script.check_workspace(HALF_EXTENTS)
    generated = GENERATORS[scene]()
    # The YAML is the generator's output rounded to micrometres; a hand edit shows up here, on purpose,
    # so that the generator and its defaults stay the documented source of the numbers.
    for t in np.linspace(0.0, generated.duration, 400):
        assert script.target(t) == pytest.approx(generated.target(t), abs=2e-6)
    assert [e.button for e in script.events] == [e.button for e in generated.events]
    assert script_from_mapping(script_to_mapping(script)).waypoints[-1].time == script.waypoints[-1].time


def test_superimposition_acts_ahead_of_the_delay_at_the_first_obstacle():
    p = {"circle_start_time": 2.0, "circle_period": 5.0, "first_obstacle_angle_deg": 90.0,
         "one_way_delay": 0.2, "handle_lag": 0.15, "avoid_offset": 0.06}
    script = superimposition_script(p)
    passing = 2.0 + 1.25                              # a quarter turn after the start
    lead = 0.35
    # Full inward offset (toward the centre, -y at 90 degrees) around the passing time minus the lead.
    assert script.target(passing - lead) == pytest.approx([0.0, -0.06, 0.06], abs=1e-9)
    # ...and back to no offset once the robot is past it (hold 0.5 s + ramp 0.5 s).
    assert np.linalg.norm(script.target(passing - lead + 1.0)) < 1e-9


def test_superimposition_rejects_overlapping_actions():
    with pytest.raises(FicInputError, match="overlap"):
        superimposition_script({"hold": 1.5})


def test_shape_sorting_velocity_legs_travel_the_planned_distance():
    """Integrate the master's velocity law over the script's handle targets, in each mode as toggled, and check
    that the replica offset x_d' visits every piece and every hole."""
    # Without the closed-loop leg corrections (a tuning on top of the geometry, see SHAPE_SORTING_DEFAULTS), and with
    # the master's own velocity law including its dead-band (fic_core.teleoperation), the legs land on the plan.
    script = shape_sorting_script({"leg_corrections": {}})
    gain = SHAPE_SORTING_DEFAULTS["velocity_gain"]
    deadband = SHAPE_SORTING_DEFAULTS["velocity_deadband"]
    dt = 0.001
    velocity_mode = False
    offset_base = np.zeros(3)                          # x_d' at the last switch to offset mode
    desired = np.zeros(3)
    events = list(script.events)
    visited = []
    for t in np.arange(0.0, script.duration, dt):
        while events and events[0].time <= t:
            event = events.pop(0)
            if event.button == BUTTON_TOGGLE_MODE:
                assert np.linalg.norm(script.target(t)) < 1e-6   # switches only with the handle at the origin
                velocity_mode = not velocity_mode
                offset_base = desired.copy()
        handle = script.target(t)
        if velocity_mode:
            norm = np.linalg.norm(handle)
            desired = desired + (gain * handle * (1.0 - deadband / norm) * dt if norm > deadband else 0.0)
        else:
            desired = offset_base + handle
            visited.append(desired.copy())
    assert not velocity_mode                          # the script ends in offset mode, as it began
    visited = np.array(visited)
    for piece in SHAPE_SORTING_DEFAULTS["pieces"]:
        top = np.asarray(piece["piece_top"])
        pressed = top - [0.0, 0.0, SHAPE_SORTING_DEFAULTS["press_depth"]]
        assert np.min(np.linalg.norm(visited - pressed, axis=1)) < 0.003, piece["name"]
        hole = np.asarray(piece["hole_top"])
        inserted = hole - [0.0, 0.0, SHAPE_SORTING_DEFAULTS["insert_margin"]]
        assert np.min(np.linalg.norm(visited - inserted, axis=1)) < 0.003, piece["name"]


def test_bad_scripts_are_refused(tmp_path):
    with pytest.raises(FicInputError, match="increase"):
        script_from_mapping({"name": "x", "waypoints": [{"t": 1.0, "position": [0, 0, 0]},
                                                        {"t": 1.0, "position": [0, 0, 0]}]})
    with pytest.raises(FicInputError, match="button"):
        script_from_mapping({"name": "x", "waypoints": [{"t": 0.0, "position": [0, 0, 0]}],
                             "events": [{"t": 0.0, "button": "self_destruct"}]})
    with pytest.raises(FicInputError, match="outside the workspace"):
        script_from_mapping({"name": "x", "waypoints": [{"t": 0.0, "position": [0.2, 0, 0]}]}
                            ).check_workspace(HALF_EXTENTS)
    (tmp_path / "bad.yaml").write_text("- just a list\n")
    with pytest.raises(FicInputError, match="mapping"):
        load_script(tmp_path / "bad.yaml")
