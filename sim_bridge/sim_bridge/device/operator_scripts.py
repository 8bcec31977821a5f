"""Scenario scripts for the virtual operator, one generator per scene (paper Sec. III; docs/EXPERIMENTS.md).

Each generator turns a few scene numbers (obstacle angles, piece and hole positions, the master's velocity gain)
into an ``OperatorScript`` of timed handle targets and button presses. The checked-in YAML files in
config/operator_scripts/ are their output with the default numbers, so users can edit a script by hand or
regenerate it with other numbers:

    python -m sim_bridge.device.operator_scripts --write config/operator_scripts

Conventions every script relies on (they are the master's, docs/CONTROL_LAWS.md):
- haptic_base axes are the robot base axes and the workspace scale s_M is 1, so a handle offset is a
  replica offset;
- the master starts in OFFSET mode, and every ``toggle_mode`` press is made with the handle back at its origin,
  so the mode switch does not move x_d' (the master keeps x_d' continuous anyway);
- in VELOCITY mode x_d' integrates k_v * x_M: a travel D is a handle excursion of area |D| / k_v along D.

Superimposition (E1): the robot circles autonomously (0.20 m diameter, 5 s period); the operator sees each
obstacle coming and acts early by the one-way delay plus the handle's lag, so that the offset reaches the
replica as the robot reaches the obstacle. Around the FIRST obstacle the operator pulls the robot inward by
``avoid_offset`` and up by ``avoid_lift`` (passing inside and over it) on every lap; at the SECOND obstacle, on the
first lap, the operator takes the robot inside the circle and sweeps it outward through the obstacle, pushing it off the
circle's path.

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
from sim_bridge.device.haptic_device import HapticDeviceParameters
from sim_bridge.device.virtual_operator import (
    BUTTON_HAPTIC_GAIN_DOWN,
    BUTTON_HAPTIC_GAIN_UP,
    BUTTON_TOGGLE_MODE,
    OperatorScript,
    ScriptEvent,
    Waypoint,
    script_to_mapping,
)
from sim_bridge.robot.scenes import PIECE_HEIGHT, SHAPE_SORTING_PIECES

WORKSPACE_HALF_EXTENTS = np.array(HapticDeviceParameters().half_extents)

SUPERIMPOSITION_DEFAULTS: dict[str, Any] = {
    # sim_bridge/robot/scenes.py: the circle is centred between the two obstacles, which sit on its path on opposite
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
    "avoid_early": 0.3,                 # [s] the lift over the first obstacle starts and ends this much earlier
                                        #     (its return does not): the hand, 0.2 m wide along the path, meets
                                        #     the obstacle's near edge about 1 s before the TCP passes its centre
    "ramp": 0.5,                        # [s] hand moves between offsets
    "push_hold": 0.3,                   # [s] held outward after the sweep through the second obstacle
    "laps": 6,                          # laps scripted (the first obstacle is avoided on each): the 30 s main job
}

#: The replica's desired TCP position while x_d' = 0 in the E2 run: the planner's fixed point (config/planner.yaml
#: ``fixed_point``; E2 runs with ``--trajectory fixed``). Every shape-sorting position below is relative to it.
SHAPE_SORTING_REFERENCE = (0.45, 0.0, 0.35)


def shape_sorting_pieces(reference=SHAPE_SORTING_REFERENCE) -> list[dict[str, Any]]:
    """Each piece's top face centre and its hole's centre on the box's top face, from sim_bridge.robot.scenes (the scene
    the robot sim builds), relative to ``reference``: the TCP (the plate's lower face) on the piece's top face."""
    origin = np.asarray(reference, dtype=float)
    return [{"name": piece.shape,
             "piece_top": np.round(np.asarray(piece.start_position) + [0.0, 0.0, PIECE_HEIGHT / 2] - origin,
                                   6).tolist(),
             "hole_top": np.round(np.asarray(piece.hole_position) - origin, 6).tolist(),
             "height": PIECE_HEIGHT}
            for piece in SHAPE_SORTING_PIECES]


SHAPE_SORTING_DEFAULTS: dict[str, Any] = {
    # Positions are relative to the replica's desired TCP position when the script starts (x_d' = 0), in the
    # robot base axes: SHAPE_SORTING_REFERENCE, the planner's fixed point. The pieces and holes come from
    # sim_bridge/robot/scenes.py (shape_sorting_pieces), so the script follows the scene's layout.
    "velocity_gain": 2.0,               # k_v of the master's velocity mode [1/s]: must match config/master.yaml
    "velocity_deadband": 0.005,         # [m] the master's velocity dead-band (config/master.yaml): the travel
                                        #     integrates k_v*(|x_M| - deadband), so the holds are lengthened for it
    "reference": list(SHAPE_SORTING_REFERENCE),
    "pieces": shape_sorting_pieces(),
    "hover": 0.03,                      # [m] above a piece before descending onto it
    "press_depth": 0.03,                # [m] commanded below the contact: K0*0.03 ~ 6 N > the bond's 3 N to form
    "bond_time": 1.0,                   # [s] pressed on the piece
    "clearance": 0.02,                  # [m] between the piece's bottom and the box top while travelling
    "insert_margin": 0.005,             # [m] commanded below the rim once the piece is fully in
    "entry_depth": 0.03,                # [m] the piece's bottom below the lid while searching for the hole: deep
                                        #     enough to press on the lid (<= K0*0.03 = 6 N) despite ~2 cm of z drift
    "search_radius": 0.015,             # [m] spiral search about the hole at entry depth (0: none)
    "search_time": 4.0,                 # [s] of the spiral
    "search_turns": 3,                  # turns of the spiral (its pitch is search_radius / search_turns)
    "lock_shift": 0.06,                 # [m] sideways (x) push that jams the piece against the hole's wall
    "pull": 0.06,                       # [m] handle raise that pulls until the bond breaks
    "pull_time": 2.5,                   # [s] held pulling
    "travel_displacement": 0.05,        # [m] handle excursion while travelling in velocity mode
    "ramp": 0.5,                        # [s] hand moves between targets
    "settle": 1.5,                      # [s] wait with the handle at rest before a mode switch (the operator's
                                        #     lean-in unwinds; 0.6 s left centimetres of drift in the closed loop)
    # {"<piece>:<leg>": [dx, dy, dz]} [m] added to where a travel leg ends. Measured in the closed loop: the misses of
    # x_d' at each leg's end in one run of the in-process runner (settle 1.5 s, a 12 mm search), half of each leg's
    # own miss taken out. The misses come from the operator
    # model's lean-in (Hand correction) winding up in contacts and from the handle's lag, which the velocity mode
    # integrates. With these and the numbers above the runner put all three pieces in the box (seed 1); the graph's
    # own result is E2 in results/e2.json.
    "leg_corrections": {
        "cuboid:across": [0.00058, 0.00005, 0.00000],
        "cuboid:down": [0.00056, 0.00210, 0.00027],
        "cuboid:up": [0.00000, 0.00000, 0.00000],
        "cuboid_hole:across": [-0.00177, 0.00003, 0.00224],
        "cuboid_hole:down": [0.00000, 0.00000, 0.00000],
        "cuboid_hole:up": [-0.00001, 0.00002, -0.00861],
        "octagonal_prism:across": [0.01108, -0.00165, 0.00387],
        "octagonal_prism:down": [-0.00230, 0.00115, -0.00125],
        "octagonal_prism:up": [0.00123, 0.00000, -0.00440],
        "octagonal_prism_hole:across": [-0.00027, 0.00000, -0.00169],
        "octagonal_prism_hole:down": [0.00000, 0.00000, 0.00000],
        "octagonal_prism_hole:up": [0.00231, -0.00087, 0.00291],
        "star_prism:across": [0.01084, -0.00152, 0.00261],
        "star_prism:down": [-0.00165, 0.00102, 0.00110],
        "star_prism:up": [0.00127, 0.00000, -0.00098],
        "star_prism_hole:across": [-0.00027, -0.00000, -0.00170],
        "star_prism_hole:down": [0.00000, 0.00000, 0.00000],
        "star_prism_hole:up": [0.00184, -0.00070, 0.00260]
    },
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
        early = float(p["avoid_early"])
        actions.append([(t - early - hold - ramp, np.zeros(3)), (t - early - hold, inward), (t + hold, inward),
                        (t + hold + ramp, np.zeros(3))])
    t = passing_time(p["second_obstacle_angle_deg"], 0) - lead
    inside, outside = -float(p["push_inward"]) * second, float(p["push_outward"]) * second
    actions.append([(t - hold - ramp, np.zeros(3)), (t - hold, inside), (t - 0.1, inside), (t + hold, outside),
                    (t + hold + push_hold, outside), (t + hold + push_hold + ramp, np.zeros(3))])
    builder = _ScriptBuilder()
    for action in sorted(actions, key=lambda a: a[0][0]):
        # At a long delay the first lap's moves would start before the run: the part before t = 0 is left out
        # (the hand moves from rest at t = 0 to the move's first point after it).
        action = [(time, position) for time, position in action if time > 0.0]
        if not action:
            continue
        start_time, start_position = action[0]
        last = builder.waypoints[-1]
        if start_time <= last.time and not start_position.any() and not last.position.any():
            action = action[1:]  # it would start at rest before the previous action has ended: start from its end
        for time, position in action:
            builder.at(time, position)
    builder.wait(2.0)
    script = OperatorScript("superimposition", tuple(builder.waypoints), (), "smooth",
                            "E1: steer around the first obstacle on every lap, push the second one away on the "
                            "first lap (offset mode, handle coordinates = replica offset).", p)
    script.check_workspace(WORKSPACE_HALF_EXTENTS)
    return script


def _ramp_area(displacement: float, deadband: float, ramp: float) -> float:
    """Integral over one smoothstep ramp (0 -> displacement in ``ramp`` s) of max(0, x - deadband)."""
    u = (np.arange(2000) + 0.5) / 2000
    s = u ** 3 * (10.0 - 15.0 * u + 6.0 * u ** 2)
    return float(ramp * np.mean(np.maximum(0.0, displacement * s - deadband)))


def _velocity_leg(builder: _ScriptBuilder, travel: np.ndarray, p: Mapping[str, Any]) -> None:
    """One straight travel in VELOCITY mode: a handle excursion whose area is travel / k_v (the velocity mode,
    docs/CONTROL_LAWS.md)."""
    distance = float(np.linalg.norm(travel))
    if distance < 1e-6:
        return
    direction = travel / distance
    limits = 0.8 * WORKSPACE_HALF_EXTENTS
    with np.errstate(divide="ignore"):
        fits = np.min(np.where(np.abs(direction) > 1e-9, limits / np.abs(direction), np.inf))
    displacement = min(float(p["travel_displacement"]), float(fits))
    ramp = float(p["ramp"])
    deadband = float(p.get("velocity_deadband", 0.0))
    area = distance / float(p["velocity_gain"])
    # The master integrates k_v*(|x_M| - deadband) (fic_core.teleoperation): per ramp of the quintic smoothstep
    # that is ramp * mean(max(0, d*s(u) - deadband)), and (d - deadband) per second of hold.
    hold = (area - 2.0 * _ramp_area(displacement, deadband, ramp)) / (displacement - deadband)
    if hold < 0.0:
        low, high = deadband, displacement  # a shorter excursion without hold: bisect its displacement
        for _ in range(60):
            middle = 0.5 * (low + high)
            low, high = (middle, high) if 2.0 * _ramp_area(middle, deadband, ramp) < area else (low, middle)
        displacement, hold = 0.5 * (low + high), 0.0
    builder.move(displacement * direction, ramp)
    if hold > 0.0:
        builder.wait(hold)
    builder.move(np.zeros(3), ramp)
    builder.wait(float(p["settle"]))


def shape_sorting_script(overrides: Mapping[str, Any] | None = None) -> OperatorScript:
    p = {**SHAPE_SORTING_DEFAULTS, **(overrides or {})}
    if overrides and "reference" in overrides and "pieces" not in overrides:
        p["pieces"] = shape_sorting_pieces(p["reference"])
    ramp, settle = float(p["ramp"]), float(p["settle"])
    corrections = {key: np.asarray(value, dtype=float) for key, value in dict(p["leg_corrections"]).items()}
    builder = _ScriptBuilder()
    builder.wait(1.0)
    position = np.zeros(3)       # replica offset reached so far (x_d' relative to the start)

    leg_ends: dict[str, list[float]] = {}   # "<piece>:<leg>" -> [time the leg has settled, x, y, z planned]

    def travel(name: str, legs: list[tuple[str, np.ndarray]]) -> None:
        nonlocal position
        builder.press(BUTTON_TOGGLE_MODE)
        for leg, waypoint in legs:
            # A correction measured in the closed loop moves where the leg ends; later legs still aim at the
            # planned waypoints, so a correction does not accumulate.
            key = f"{name}:{leg}"
            _velocity_leg(builder, waypoint + corrections.get(key, np.zeros(3)) - position, p)
            position = np.asarray(waypoint, dtype=float)
            leg_ends[key] = [round(builder.time, 6), *np.round(position, 6).tolist()]
        builder.press(BUTTON_TOGGLE_MODE)

    for piece in p["pieces"]:
        name = piece["name"]
        piece_top, hole_top = np.asarray(piece["piece_top"], float), np.asarray(piece["hole_top"], float)
        height = float(piece["height"])
        travel_z = max(piece_top[2], hole_top[2]) + height + float(p["clearance"])
        hover = piece_top + [0.0, 0.0, float(p["hover"])]
        # Travel (VELOCITY): up to the travel height, across, down to hover over the piece.
        travel(name, [("up", np.array([position[0], position[1], max(position[2], travel_z)])),
                      ("across", np.array([hover[0], hover[1], max(position[2], travel_z)])),
                      ("down", hover)])
        # Pick (OFFSET): descend past the contact so the bond forms under pressure, then lift.
        builder.press(BUTTON_HAPTIC_GAIN_UP)
        builder.move([0.0, 0.0, -(float(p["hover"]) + float(p["press_depth"]))], 2.0 * ramp)
        builder.wait(float(p["bond_time"]))
        builder.move(np.zeros(3), 2.0 * ramp)
        builder.wait(settle)
        builder.press(BUTTON_HAPTIC_GAIN_DOWN)
        # Travel (VELOCITY) with the piece: up, across, down to just above the hole.
        above_hole = hole_top + [0.0, 0.0, height + float(p["clearance"])]
        travel(f"{name}_hole", [("up", np.array([position[0], position[1], travel_z])),
                                ("across", np.array([above_hole[0], above_hole[1], travel_z])),
                                ("down", above_hole)])
        # Insert (OFFSET): the piece's bottom just into the lid, a spiral search at that depth with a light press
        # (a piece resting on the rim is not pressed hard enough to break its bond), then fully in.
        builder.press(BUTTON_HAPTIC_GAIN_UP)
        entry = -(float(p["clearance"]) + float(p["entry_depth"]))
        builder.move([0.0, 0.0, entry], 2.0 * ramp)
        radius = float(p["search_radius"])
        if radius > 0.0:
            turns = int(p["search_turns"])
            samples = 12 * turns
            for k in range(1, samples + 1):
                angle = 2.0 * math.pi * turns * k / samples
                r = radius * k / samples
                builder.move([r * math.cos(angle), r * math.sin(angle), entry], float(p["search_time"]) / samples)
            builder.move([0.0, 0.0, entry], ramp)
        insert = -(height + float(p["clearance"]) + float(p["insert_margin"]))
        builder.move([0.0, 0.0, insert], 2.0 * ramp)
        builder.wait(0.5)
        # Lock: push sideways so the piece jams against its hole's wall; pull up until the bond breaks.
        builder.move([float(p["lock_shift"]), 0.0, insert], 2.0 * ramp)
        builder.wait(0.5)
        builder.move([float(p["lock_shift"]), 0.0, float(p["pull"])], 2.0 * ramp)
        builder.wait(float(p["pull_time"]))
        builder.move([0.0, 0.0, float(p["pull"])], 2.0 * ramp)
        builder.move(np.zeros(3), 2.0 * ramp)
        builder.wait(settle)
        builder.press(BUTTON_HAPTIC_GAIN_DOWN)
    builder.wait(2.0)
    script = OperatorScript("shape_sorting", tuple(builder.waypoints), tuple(builder.events), "smooth",
                            "E2: travel in velocity mode, pick/insert/lock/pull in offset mode, per piece.",
                            {**p, "pieces": [dict(piece) for piece in p["pieces"]],
                             "leg_corrections": {k: np.round(v, 6).tolist() for k, v in corrections.items()},
                             "leg_ends": leg_ends})
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


def write_script(script: OperatorScript, path: Path) -> Path:
    """One script as YAML, with the header the checked-in files carry."""
    header = (f"# Operator script for the '{script.name}' scene, generated by sim_bridge/device/operator_scripts.py "
              "with the\n"
              "# numbers under 'parameters'. Edit by hand, or regenerate with other numbers. Waypoints: handle\n"
              "# targets [m] in haptic_base at t [s] from the script's start; events: button presses.\n")
    path.write_text(header + yaml.safe_dump(_plain(script_to_mapping(script)), sort_keys=False,
                                            default_flow_style=None, width=120))
    return path


def write_scripts(directory: Path) -> list[Path]:
    directory.mkdir(parents=True, exist_ok=True)
    return [write_script(generator(), directory / f"{name}.yaml") for name, generator in GENERATORS.items()]


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
