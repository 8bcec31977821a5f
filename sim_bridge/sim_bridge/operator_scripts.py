"""Scenario scripts for the virtual operator, one generator per scene (paper Sec. III; SPEC 3).

Each generator turns a few scene numbers (obstacle angles, piece and hole positions, the master's velocity gain)
into an ``OperatorScript`` of timed handle targets and button presses. The checked-in YAML files in
config/operator_scripts/ are their output with the default numbers, so users can edit a script by hand or
regenerate it with other numbers:

    python -m sim_bridge.operator_scripts --write config/operator_scripts

Conventions every script relies on (they are the master's, SPEC 1.3):
- haptic_base axes are the robot base axes and the workspace scale s_M is 1, so a handle offset is a
  replica offset;
- the master starts in OFFSET mode, and every ``toggle_mode`` press is made with the handle back at its origin,
  so the mode switch does not move x_d' (the master keeps x_d' continuous anyway);
- in VELOCITY mode x_d' integrates k_v * x_M: a travel D is a handle excursion of area |D| / k_v along D.

Superimposition (E1): the robot circles autonomously (0.20 m diameter, 5 s period); the operator sees each
obstacle coming and acts early by the one-way delay plus the handle's lag, so that the offset reaches the
replica as the robot reaches the obstacle. Around the FIRST obstacle the operator pulls the robot inward by
``avoid_offset`` and up by ``avoid_lift`` (passing inside and over it) on every lap; at the SECOND obstacle, on the first lap, the operator takes
the robot inside the circle and sweeps it outward through the obstacle, pushing it off the circle's path.

Shape sorting (E2): the device's 0.19 m x 0.13 m workspace cannot span a table, and a larger workspace scale
would multiply the hand's tremor and the handle lag by the same factor exactly when millimetres matter. So the
script does what the paper's velocity-based teleoperation is for: it TRAVELS in VELOCITY mode (lift, move over,
descend: one handle excursion per straight leg) and does every contact move in OFFSET mode with s_M = 1 (descend
to touch and press so the adhesive bond forms, lift, insert, press against the rim, shift sideways to lock the
piece under the rim, pull up until the bond breaks). K_H is raised before each contact phase and lowered after.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import yaml

from fic_core.errors import FicInputError
from sim_bridge.haptic_device import HapticDeviceParameters
from sim_bridge.virtual_operator import (BUTTON_HAPTIC_GAIN_DOWN, BUTTON_HAPTIC_GAIN_UP, BUTTON_TOGGLE_MODE,
                                         OperatorScript, ScriptEvent, Waypoint, script_to_mapping)

WORKSPACE_HALF_EXTENTS = np.array(HapticDeviceParameters().half_extents)

SUPERIMPOSITION_DEFAULTS: dict[str, Any] = {
    # sim_bridge/scenes.py: the circle is centred between the two obstacles, which sit on its path on opposite
    # sides, FIXED_OBSTACLE_POSITION at +y (90 deg) and PUSHABLE_OBSTACLE_POSITION at -y (270 deg). The circle's
    # start time and angle are the planner's: check them against its configuration.
    "circle_radius": 0.10,              # [m] paper: 0.20 m diameter
    "circle_period": 5.0,               # [s] paper: 5 s
    "circle_start_time": 2.0,           # [s] script time at which the robot is at circle_start_angle
    "circle_start_angle_deg": 0.0,      # [deg] angle of the robot on the circle at circle_start_time
    "circle_direction": 1,              # +1 counter-clockwise seen from above, -1 clockwise
    "first_obstacle_angle_deg": 90.0,   # [deg] obstacle to steer around
    "second_obstacle_angle_deg": 270.0,  # [deg] obstacle to push away
    "one_way_delay": 0.2,               # [s] the channel's delay the operator anticipates (paper: ~200 ms)
    "handle_lag": 0.15,                 # [s] how long the handle takes to follow the hand
    "avoid_offset": 0.06,               # [m] inward offset while passing the first obstacle
    "avoid_lift": 0.06,                 # [m] upward offset while passing it (scenes.py: its top is 0.03 m above
                                        #     the circle's plane, and the handle's +-0.065 m cannot go around a
                                        #     0.06 m wide obstacle with a 0.07 m plate by a side step alone)
    "push_inward": 0.05,                # [m] inward offset before the sweep through the second obstacle
    "push_outward": 0.06,               # [m] outward offset at the end of the sweep
    "hold": 0.5,                        # [s] full offset held each side of the passing time
    "ramp": 0.5,                        # [s] hand moves between offsets
    "push_hold": 0.3,                   # [s] held outward after the sweep through the second obstacle
    "laps": 3,                          # laps scripted (the first obstacle is avoided on each)
}

SHAPE_SORTING_DEFAULTS: dict[str, Any] = {
    # Positions are relative to the replica's desired TCP position when the script starts (x_d' = 0), in the
    # robot base axes. Until sim_bridge/scenes.py exports the layout these are the assumed one: pieces on the
    # table in front, the box behind with its holes' centres on its top face.
    "velocity_gain": 2.0,               # k_v of the master's velocity mode [1/s]: must match the master's
    "pieces": [
        {"name": "cuboid", "piece_top": [0.10, -0.15, -0.20], "hole_top": [-0.10, -0.06, -0.10], "height": 0.04},
        {"name": "octagonal_prism", "piece_top": [0.10, 0.0, -0.20], "hole_top": [-0.10, 0.0, -0.10],
         "height": 0.04},
        {"name": "star_prism", "piece_top": [0.10, 0.15, -0.20], "hole_top": [-0.10, 0.06, -0.10],
         "height": 0.04},
    ],
    "hover": 0.04,                      # [m] above a piece before descending onto it
    "press_depth": 0.015,               # [m] commanded below the contact so the FIC presses the bond shut
    "bond_time": 1.0,                   # [s] pressed on the piece
    "clearance": 0.02,                  # [m] between the piece's bottom and the box top while travelling
    "insert_margin": 0.005,             # [m] commanded below the rim once the piece is fully in
    "lock_shift": 0.015,                # [m] sideways shift (x) that hooks the piece under the rim
    "pull": 0.06,                       # [m] handle raise that pulls until the bond breaks
    "pull_time": 2.5,                   # [s] held pulling
    "travel_displacement": 0.05,        # [m] handle excursion while travelling in velocity mode
    "ramp": 0.5,                        # [s] hand moves between targets
    "settle": 0.6,                      # [s] wait with the handle at rest before a mode switch
}

FREE_SPACE_DEFAULTS: dict[str, Any] = {
    "reach": [0.06, 0.04, 0.04],        # [m] handle target to reach
    "start": 1.0,                       # [s]
    "move_time": 1.5,                   # [s] each way
    "hold": 2.0,                        # [s] at the reach point
}


class _ScriptBuilder:
    """Accumulates waypoints and events on a running clock."""

    def __init__(self) -> None:
        self.time = 0.0
        self.waypoints: list[Waypoint] = [Waypoint(0.0, np.zeros(3))]
        self.events: list[ScriptEvent] = []

    def move(self, position: Sequence[float], duration: float) -> None:
        self.time += duration
        self.waypoints.append(Waypoint(self.time, np.asarray(position, dtype=float)))

    def wait(self, duration: float) -> None:
        self.move(self.waypoints[-1].position, duration)

    def press(self, button: int) -> None:
        self.events.append(ScriptEvent(self.time, button))

    def at(self, time: float, position: Sequence[float]) -> None:
        if time <= self.waypoints[-1].time:
            raise FicInputError(f"scripted actions overlap at t={time:.3f} s: widen the spacing or shorten "
                                "hold/ramp")
        self.time = time
        self.waypoints.append(Waypoint(time, np.asarray(position, dtype=float)))


def superimposition_script(overrides: Mapping[str, Any] | None = None) -> OperatorScript:
    p = {**SUPERIMPOSITION_DEFAULTS, **(overrides or {})}
    period, direction = float(p["circle_period"]), int(p["circle_direction"])
    lead = float(p["one_way_delay"]) + float(p["handle_lag"])
    hold, ramp, push_hold = float(p["hold"]), float(p["ramp"]), float(p["push_hold"])

    def passing_time(angle_deg: float, lap: int) -> float:
        travel = (direction * math.radians(angle_deg - float(p["circle_start_angle_deg"]))) % (2.0 * math.pi)
        return float(p["circle_start_time"]) + travel / (2.0 * math.pi) * period + lap * period

    def radial(angle_deg: float) -> np.ndarray:
        angle = math.radians(angle_deg)
        return np.array([math.cos(angle), math.sin(angle), 0.0])

    actions = []   # (start of the action, list of (time, position))
    first, second = radial(p["first_obstacle_angle_deg"]), radial(p["second_obstacle_angle_deg"])
    for lap in range(int(p["laps"])):
        t = passing_time(p["first_obstacle_angle_deg"], lap) - lead
        inward = -float(p["avoid_offset"]) * first + [0.0, 0.0, float(p["avoid_lift"])]
        actions.append([(t - hold - ramp, np.zeros(3)), (t - hold, inward), (t + hold, inward),
                        (t + hold + ramp, np.zeros(3))])
    t = passing_time(p["second_obstacle_angle_deg"], 0) - lead
    inside, outside = -float(p["push_inward"]) * second, float(p["push_outward"]) * second
    actions.append([(t - hold - ramp, np.zeros(3)), (t - hold, inside), (t - 0.1, inside), (t + hold, outside),
                    (t + hold + push_hold, outside), (t + hold + push_hold + ramp, np.zeros(3))])
    builder = _ScriptBuilder()
    for action in sorted(actions, key=lambda a: a[0][0]):
        for time, position in action:
            builder.at(time, position)
    builder.wait(2.0)
    script = OperatorScript("superimposition", tuple(builder.waypoints), (), "smooth",
                            "E1: steer around the first obstacle on every lap, push the second one away on the "
                            "first lap (offset mode, handle coordinates = replica offset).", p)
    script.check_workspace(WORKSPACE_HALF_EXTENTS)
    return script


def _velocity_leg(builder: _ScriptBuilder, travel: np.ndarray, p: Mapping[str, Any]) -> None:
    """One straight travel in VELOCITY mode: a handle excursion whose area is travel / k_v (SPEC 1.3)."""
    distance = float(np.linalg.norm(travel))
    if distance < 1e-6:
        return
    direction = travel / distance
    limits = 0.8 * WORKSPACE_HALF_EXTENTS
    with np.errstate(divide="ignore"):
        fits = np.min(np.where(np.abs(direction) > 1e-9, limits / np.abs(direction), np.inf))
    displacement = min(float(p["travel_displacement"]), float(fits))
    ramp = float(p["ramp"])
    area = distance / float(p["velocity_gain"])
    # A smoothstep ramp up and down has the area of a half-ramp each, so the excursion's area is d*(ramp+hold).
    hold = area / displacement - ramp
    if hold < 0.0:
        displacement, hold = area / ramp, 0.0
    builder.move(displacement * direction, ramp)
    if hold > 0.0:
        builder.wait(hold)
    builder.move(np.zeros(3), ramp)
    builder.wait(float(p["settle"]))


def shape_sorting_script(overrides: Mapping[str, Any] | None = None) -> OperatorScript:
    p = {**SHAPE_SORTING_DEFAULTS, **(overrides or {})}
    ramp, settle = float(p["ramp"]), float(p["settle"])
    builder = _ScriptBuilder()
    builder.wait(1.0)
    position = np.zeros(3)       # replica offset reached so far (x_d' relative to the start)
    for piece in p["pieces"]:
        piece_top, hole_top = np.asarray(piece["piece_top"], float), np.asarray(piece["hole_top"], float)
        height = float(piece["height"])
        travel_z = max(piece_top[2], hole_top[2]) + height + float(p["clearance"])
        hover = piece_top + [0.0, 0.0, float(p["hover"])]
        # Travel (VELOCITY): up to the travel height, across, down to hover over the piece.
        builder.press(BUTTON_TOGGLE_MODE)
        for waypoint in ([position[0], position[1], max(position[2], travel_z)],
                         [hover[0], hover[1], max(position[2], travel_z)], hover):
            _velocity_leg(builder, np.asarray(waypoint) - position, p)
            position = np.asarray(waypoint, dtype=float)
        builder.press(BUTTON_TOGGLE_MODE)
        # Pick (OFFSET): descend past the contact so the bond forms under pressure, then lift.
        builder.press(BUTTON_HAPTIC_GAIN_UP)
        builder.move([0.0, 0.0, -(float(p["hover"]) + float(p["press_depth"]))], 2.0 * ramp)
        builder.wait(float(p["bond_time"]))
        builder.move(np.zeros(3), 2.0 * ramp)
        builder.wait(settle)
        builder.press(BUTTON_HAPTIC_GAIN_DOWN)
        # Travel (VELOCITY) with the piece: up, across, down to just above the hole.
        above_hole = hole_top + [0.0, 0.0, height + float(p["clearance"])]
        builder.press(BUTTON_TOGGLE_MODE)
        for waypoint in ([position[0], position[1], travel_z], [above_hole[0], above_hole[1], travel_z],
                         above_hole):
            _velocity_leg(builder, np.asarray(waypoint) - position, p)
            position = np.asarray(waypoint, dtype=float)
        builder.press(BUTTON_TOGGLE_MODE)
        # Insert, press on the rim, lock sideways, pull until the bond breaks (OFFSET).
        builder.press(BUTTON_HAPTIC_GAIN_UP)
        insert = -(height + float(p["clearance"]) + float(p["insert_margin"]))
        builder.move([0.0, 0.0, insert], 2.0 * ramp)
        builder.wait(0.5)
        builder.move([float(p["lock_shift"]), 0.0, insert], ramp)
        builder.wait(0.5)
        builder.move([float(p["lock_shift"]), 0.0, float(p["pull"])], 2.0 * ramp)
        builder.wait(float(p["pull_time"]))
        builder.move(np.zeros(3), 2.0 * ramp)
        builder.wait(settle)
        builder.press(BUTTON_HAPTIC_GAIN_DOWN)
    builder.wait(2.0)
    script = OperatorScript("shape_sorting", tuple(builder.waypoints), tuple(builder.events), "smooth",
                            "E2: travel in velocity mode, pick/insert/lock/pull in offset mode, per piece.",
                            {**p, "pieces": [dict(piece) for piece in p["pieces"]]})
    script.check_workspace(WORKSPACE_HALF_EXTENTS)
    return script


def free_space_script(overrides: Mapping[str, Any] | None = None) -> OperatorScript:
    p = {**FREE_SPACE_DEFAULTS, **(overrides or {})}
    builder = _ScriptBuilder()
    builder.wait(float(p["start"]))
    builder.move(p["reach"], float(p["move_time"]))
    builder.wait(float(p["hold"]))
    builder.move(np.zeros(3), float(p["move_time"]))
    builder.wait(1.0)
    script = OperatorScript("free_space", tuple(builder.waypoints), (), "smooth",
                            "Reach to a point in offset mode, hold, return.", p)
    script.check_workspace(WORKSPACE_HALF_EXTENTS)
    return script


GENERATORS = {"superimposition": superimposition_script, "shape_sorting": shape_sorting_script,
              "free_space": free_space_script}


def write_scripts(directory: Path) -> list[Path]:
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for name, generator in GENERATORS.items():
        path = directory / f"{name}.yaml"
        header = (f"# Operator script for the '{name}' scene, generated by sim_bridge/operator_scripts.py with the\n"
                  "# numbers under 'parameters'. Edit by hand, or regenerate with other numbers. Waypoints: handle\n"
                  "# targets [m] in haptic_base at t [s] from the script's start; events: button presses.\n")
        path.write_text(header + yaml.safe_dump(_plain(script_to_mapping(generator())), sort_keys=False,
                                                default_flow_style=None, width=120))
        written.append(path)
    return written


def _plain(value: Any) -> Any:
    """numpy scalars and arrays to plain Python, so the YAML stays readable."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Write the default operator scripts as YAML files.")
    parser.add_argument("--write", type=Path, required=True, help="directory to write <scene>.yaml into")
    for path in write_scripts(parser.parse_args(argv).write):
        print(path)


if __name__ == "__main__":
    main()
