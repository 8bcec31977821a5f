#!/usr/bin/env python3
"""A fast in-process twin of the teleoperation graph, to tune the E2 operator script (NOT an experiment result).

    .venv/bin/python scripts/e2_twin.py [--script config/operator_scripts/shape_sorting.yaml] [--seed 1]

The graph in lockstep runs at 0.1-0.3x real time on this shared 2-core machine; tuning the shape-sorting script
against it costs ~10 minutes a try. This twin wires the same pure cores the nodes are thin shells around, in one
process at 1 kHz: the scripted operator's hand and the simulated device (haptic_device_node), the master's FIC
and the teleoperation integrator (master_node, 500 Hz force, 250 Hz network), a fixed-delay channel both ways,
the replica (replica_node: x_d = x_d'' + x_d', the planner's fixed point approached at resume_speed, desired
velocity filter, the torque slewed at the torque-rate limit) and the MuJoCo Panda with the adhesive bond. It is
approximate (no DDS timing, button presses applied at once) and only tells where the script's moves land; every
reported E2 figure comes from the real graph (scripts/experiments.sh).
"""
from __future__ import annotations

import argparse
import collections
import math
import sys
import time
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parent.parent

from fic_core import (ForceProfile, NullSpacePosture, PandaLimits, PosturalOptimisation, PoseAttractor,  # noqa: E402
                      ReplicaController, RobotModel)
from fic_core.attractor import FractalAttractor  # noqa: E402
from fic_core.master import MasterLaw  # noqa: E402
from fic_core.teleoperation import TeleoperationCommandIntegrator  # noqa: E402
from sim_bridge.experiments.shape_sorting import PIECE_NAMES, inside_box  # noqa: E402
from sim_bridge.device.haptic_device import HapticDevice, HapticDeviceParameters  # noqa: E402
from sim_bridge.robot.mujoco_panda import PandaSimulation  # noqa: E402
from sim_bridge.device.virtual_operator import (BUTTON_HAPTIC_GAIN_DOWN, BUTTON_HAPTIC_GAIN_UP, BUTTON_TOGGLE_MODE,  # noqa: E402
                                         Hand, HandParameters, ScriptedOperator, load_script)


def params(name: str) -> dict:
    data = yaml.safe_load((REPO / "config" / name).read_text())
    return next(iter(data.values()))["ros__parameters"]


def run(script_path: Path, seed: int, delay: float, duration: float | None, verbose: bool) -> dict:
    r, m, h, pl = params("replica.yaml"), params("master.yaml"), params("haptic_device.yaml"), params("planner.yaml")
    sim = PandaSimulation("shape_sorting", seed)
    robot = RobotModel()
    limits = PandaLimits.from_robot(robot)
    controller = PoseAttractor(
        ForceProfile(r["translation_stiffness"], r["translation_saturation_error"], r["translation_saturation_start"],
                     r["translation_max_force"]),
        ForceProfile(r["rotation_stiffness"], r["rotation_saturation_error"], r["rotation_saturation_start"],
                     r["rotation_max_force"]), r["rate_deadband_translation"], r["rate_deadband_rotation"])
    posture = NullSpacePosture(robot.lower_position_limit, robot.upper_position_limit, stiffness=r["posture_stiffness"],
                               damping=r["posture_damping"], limit_band=r["posture_limit_band"],
                               limit_stiffness=r["posture_limit_stiffness"])
    dt = 0.001
    replica = ReplicaController(robot, controller, limits, posture, dt,
                                PosturalOptimisation(limits, dt, velocity_horizon=r["velocity_horizon"]))
    device = HapticDevice(HapticDeviceParameters(mass=h["mass"], damping=h["damping"], half_extents=tuple(h["half_extents"]),
                                                 wall_stiffness=h["wall_stiffness"], wall_damping=h["wall_damping"],
                                                 max_force=h["max_force"], substep=h["substep"]))
    hand = Hand(HandParameters(stiffness=h["hand_stiffness"], damping=h["hand_damping"],
                               correction_rate=h["hand_correction_rate"], max_correction=h["hand_max_correction"],
                               max_force=h["hand_max_force"]))
    script = load_script(script_path)
    operator = ScriptedOperator(script)
    master = MasterLaw(FractalAttractor(ForceProfile(m["stiffness"], m["saturation_error"], m["saturation_start"],
                                                     m["max_force"]), 3, m["rate_deadband"]),
                       m["haptic_gain"], m["max_device_force"] or None)
    integrator = TeleoperationCommandIntegrator(m["workspace_scale"], m["velocity_gain"], m["velocity_deadband"])
    integrator.set_mode(m["mode"])

    robot.update(sim.joint_positions, sim.joint_velocities)
    start_position, start_rotation = robot.tcp_position.copy(), robot.tcp_rotation.copy()
    planner_target = np.asarray(pl["fixed_point"], float)
    planner_in_use = start_position.copy()
    forward: collections.deque = collections.deque()   # (delivery time, x_d')
    backward: collections.deque = collections.deque()  # (delivery time, F_R)
    offset = np.zeros(3)
    feedback = np.zeros(3)
    device_force = np.zeros(3)
    desired_velocity = np.zeros(3)
    previous_desired = None
    published = None
    torque_step = limits.torque_rate * dt
    duration = duration or script.duration + 1.0
    steps = int(round(duration / dt))
    log = {"t": [], "xd": [], "x": [], "force": [], "offset": [], "pieces": []}
    events = []
    wall = time.monotonic()
    for k in range(steps):
        t = k * dt
        # --- operator side: 500 Hz device/master force, 250 Hz network --------------------------------------
        if k % 2 == 0:
            for event in operator.poll_events(t):
                if event.button == BUTTON_TOGGLE_MODE:
                    integrator.toggle_mode()
                elif event.button == BUTTON_HAPTIC_GAIN_UP:
                    master.set_haptic_gain(round(master.haptic_gain + 0.1, 6))
                elif event.button == BUTTON_HAPTIC_GAIN_DOWN:
                    master.set_haptic_gain(round(master.haptic_gain - 0.1, 6))
            hand.update(operator.target(t), device.position, 0.002)
            device.step(device_force, hand.force, 0.002)
            while backward and backward[0][0] <= t:
                feedback = backward.popleft()[1]
            device_force = master.force(device.position, device.velocity, feedback)
        if k % 4 == 0:
            forward.append((t + delay, integrator.update(device.position, 0.004).copy()))
        while forward and forward[0][0] <= t:
            offset = forward.popleft()[1]
        # --- replica ---------------------------------------------------------------------------------------------
        step = r["resume_speed"] * dt
        gap = planner_target - planner_in_use
        distance = float(np.linalg.norm(gap))
        planner_in_use = planner_target.copy() if distance <= step else planner_in_use + gap * step / distance
        desired = planner_in_use + offset
        if previous_desired is not None:
            raw = (desired - previous_desired) / dt
            desired_velocity += (raw - desired_velocity) * (dt / (r["desired_velocity_filter"] + dt))
        previous_desired = desired
        q, qd = sim.joint_positions, sim.joint_velocities
        command = replica.command(q, qd, desired, start_rotation, np.concatenate((desired_velocity, np.zeros(3))))
        target = command.torque
        if published is not None:
            target = published + np.clip(target - published, -torque_step, torque_step)
        published = target
        sim.step(published)
        wrench = sim.ft_wrench()
        if k % 4 == 0:
            backward.append((t + delay, wrench[:3].copy()))
        for message in sim.drain_bond_events():
            events.append((round(t, 3), message))
            if verbose:
                print(f"  t={t:7.3f} {message}")
        if k % 20 == 0:
            log["t"].append(t)
            log["xd"].append(desired.copy())
            log["x"].append(sim.tcp_pose[0].copy())
            log["force"].append(wrench[:3].copy())
            log["offset"].append(offset.copy())
            log["pieces"].append(np.array([p for p, _ in sim.object_poses().values()]))
    final = sim.object_poses()
    outcome = {name: {"inside": inside_box(final[name][0]), "position": np.round(final[name][0], 4).tolist()}
               for name in PIECE_NAMES}
    log = {key: np.asarray(value) for key, value in log.items()}
    return {"outcome": outcome, "events": events, "log": log, "wall_s": time.monotonic() - wall,
            "limit_violations": replica.violation_ticks, "shaped": replica.shaped_ticks}


def tune(args) -> int:
    from sim_bridge.device.operator_scripts import shape_sorting_script
    from sim_bridge.device.virtual_operator import script_to_mapping
    from sim_bridge.device.operator_scripts import _plain

    corrections = {}
    overrides = yaml.safe_load(args.overrides.read_text()) if args.overrides else {}
    if args.corrections and args.corrections.exists():
        corrections = {k: np.asarray(v, float) for k, v in (yaml.safe_load(args.corrections.read_text()) or {}).items()}
    for iteration in range(args.tune):
        script = shape_sorting_script({**overrides, "leg_corrections": {k: v.tolist() for k, v in corrections.items()}})
        path = Path(f"/tmp/e2_twin_tune_{iteration}.yaml")
        path.write_text(yaml.safe_dump(_plain(script_to_mapping(script)), sort_keys=False))
        result = run(path, args.seed, args.delay, args.duration, verbose=True)
        log = result["log"]
        print(f"iteration {iteration}: " + ", ".join(f"{n}: {'IN' if o['inside'] else 'out'}"
                                                    for n, o in result["outcome"].items()))
        # miss_k = miss_(k-1) + c_k + d_k (d_k: what leg k, and the offset-mode phase before it, add): each leg's
        # correction takes out its own increment, so upstream misses are not counted twice.
        previous = np.zeros(3)
        np.savez(f"/tmp/e2_twin_tune_{iteration}.npz", **log)
        for key, (t_end, *planned) in script.parameters["leg_ends"].items():
            realized = np.array([np.interp(t_end + args.delay, log["t"], log["offset"][:, a]) for a in range(3)])
            miss = realized - np.asarray(planned)
            corrections[key] = corrections.get(key, np.zeros(3)) - args.gain * (miss - previous)
            previous = miss
            print(f"  {key:28s} miss {np.round(miss * 1000, 1)} mm")
        if args.corrections:
            args.corrections.write_text(yaml.safe_dump({k: np.round(v, 5).tolist() for k, v in corrections.items()}))
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--script", type=Path, default=REPO / "config" / "operator_scripts" / "shape_sorting.yaml")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--delay", type=float, default=0.2)
    parser.add_argument("--duration", type=float, default=None)
    parser.add_argument("--plot", type=Path, default=None)
    parser.add_argument("--tune", type=int, default=0,
                        help="iterations of travel-leg correction: generate the script with the corrections so far, "
                             "run it, move each leg's end by minus the miss of x_d' there; prints the corrections")
    parser.add_argument("--corrections", type=Path, default=None, help="YAML of leg corrections to start from / write")
    parser.add_argument("--overrides", type=Path, default=None, help="YAML of generator parameters to override")
    parser.add_argument("--gain", type=float, default=0.5, help="share of a leg's own miss corrected per iteration")
    args = parser.parse_args(argv)
    if args.tune:
        return tune(args)
    result = run(args.script, args.seed, args.delay, args.duration, verbose=True)
    print(f"wall {result['wall_s']:.1f} s; limit violations {result['limit_violations']}, shaped {result['shaped']}")
    for name, outcome in result["outcome"].items():
        print(f"  {name}: {'INSIDE' if outcome['inside'] else 'outside'} at {outcome['position']}")
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        log = result["log"]
        fig, axes = plt.subplots(4, 1, figsize=(12, 10), sharex=True)
        for axis, label in enumerate("xyz"):
            axes[axis].plot(log["t"], log["xd"][:, axis], label="x_d")
            axes[axis].plot(log["t"], log["x"][:, axis], label="x_R")
            for p in range(log["pieces"].shape[1]):
                axes[axis].plot(log["t"], log["pieces"][:, p, axis], lw=0.7, label=PIECE_NAMES[p])
            axes[axis].set_ylabel(label)
        axes[0].legend(fontsize=7)
        axes[3].plot(log["t"], np.linalg.norm(log["force"], axis=1))
        axes[3].set_ylabel("|F|")
        fig.savefig(args.plot, dpi=80)
    return 0


if __name__ == "__main__":
    sys.exit(main())
