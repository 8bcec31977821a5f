"""The replica's law on the simulated Panda with its control ticks stretched: the peak joint speed against the
sampling period (docs/CONTROL_LAWS.md, "The law on late ticks").

In a starved graph the law runs on control ticks up to loop_max_tick_gap apart and the robot holds each torque until
the next (a zero-order hold). This runs the same ReplicaLoop (config/replica.yaml's values) on MuJoCo in process, no
ROS: the arm settles at its start pose on 2 ms ticks, gets a kick (joint velocities set at once, as a push of the
wrist would), and from then on the law ticks every ``period`` on fresh states, its torque held in between. Each line:
the period, per joint the peak |qd| over the run after the kick as a fraction of its datasheet speed, and the peak
in the last second against the first (above 1: the oscillation grows).

    python -m fic_teleop_experiments.tools.sampled_law --periods 0.002 0.02 0.035 0.045 0.048 [--kick 0 0 0 0 0.5 0.5
    0.5] python -m fic_teleop_experiments.tools.sampled_law --periods 0.02 --longest 0.048 --seeds 1 2 3 4   # intervals
    drawn

    python -m fic_teleop_experiments.tools.sampled_law --e1-seeds 1 2 3 4   # the E1 circle, ticks 20-48 ms apart from 2
    to 8 s

The robot's stale-command watchdog (config/robot.yaml's command_timeout, 50 ms) holds the arm as the robot node does,
so a period of 50 ms or more meets the loop's hold and the robot's hold, not the law.
"""
from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np
import yaml

from fic_core.limits import PANDA_JOINT_VELOCITY_LIMIT
from fic_core.replica_loop import ReplicaLoop
from fic_core.replica_parameters import REPLICA_LOOP_PARAMETERS, ReplicaLoopParameters
from fic_teleop_runtime.workspace import config_folder
from sim_bridge.robot.mujoco_panda import TIMESTEP, PandaSimulation
from sim_bridge.robot.watchdog import CommandWatchdog

DEFAULT_KICK = (0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.5)   # [rad/s] the wrist pushed
SETTLE_S = 0.5


def replica_values(**changes: Any) -> dict[str, Any]:
    """config/replica.yaml's ReplicaLoop values, changed (the realtime graph's 500 Hz control rate by default)."""
    data = yaml.safe_load((config_folder() / "replica.yaml").read_text())
    values = {name: value for name, value in next(iter(data.values()))["ros__parameters"].items()
              if name in REPLICA_LOOP_PARAMETERS}
    return {**values, "control_rate": 500.0, "command_period": 0.002, **changes}


def robot_command_timeout() -> float:
    """The simulated robot's stale-command watchdog (config/robot.yaml): an older torque gives way to its hold."""
    data = yaml.safe_load((config_folder() / "robot.yaml").read_text())
    return float(next(iter(data.values()))["ros__parameters"]["command_timeout"])


def sampled_run(period: float, kick: tuple[float, ...] = DEFAULT_KICK, duration: float = 4.0,
                longest: float | None = None, seed: int = 1, **changes: Any) -> dict[str, Any]:
    """One run (module docstring): the law every ``period`` [s] after the kick (with ``longest``: every interval
    drawn from the seed in [period, longest], as a starved replica's); per-joint peaks, growth, holds."""
    draws = np.random.default_rng(seed)
    sim = PandaSimulation("free_space", seed=1)
    replica = ReplicaLoop(ReplicaLoopParameters.from_values(replica_values(**changes)))
    limit = np.array(PANDA_JOINT_VELOCITY_LIMIT)
    steps = int(round((SETTLE_S + duration) / TIMESTEP))
    every_settle = int(round(0.002 / TIMESTEP))
    shortest = max(int(round(period / TIMESTEP)), 1)
    longest_steps = shortest if longest is None else max(int(round(longest / TIMESTEP)), shortest)
    kicked_at = int(round(SETTLE_S / TIMESTEP))
    watchdog = CommandWatchdog(robot_command_timeout())
    torque = None
    speeds = []
    next_tick = 0   # the physics step of the law's next tick: every 2 ms while settling, then drawn intervals
    for k in range(steps):
        now = k * TIMESTEP
        if k == kicked_at:
            sim.data.qvel[:7] += np.asarray(kick, dtype=float)
            next_tick = k
        if k == next_tick:
            next_tick += every_settle if k < kicked_at else int(draws.integers(shortest, longest_steps + 1))
            step = replica.joint_state(now, now, sim.joint_positions.copy(), sim.joint_velocities.copy())
            if step.torque is not None:
                torque = step.torque
                watchdog.command_received(now)
        watchdog.check(now)
        sim.step(sim.hold_torque() if torque is None or watchdog.holding else torque)
        if k >= kicked_at:
            speeds.append(np.abs(sim.joint_velocities))
    speed = np.array(speeds) / limit
    second = int(round(1.0 / TIMESTEP))
    first, last = speed[:second].max(axis=0), speed[-second:].max(axis=0)
    interval_ms = round(period * 1e3, 1) if longest is None else [round(period * 1e3, 1), round(longest * 1e3, 1)]
    return {"period_ms": interval_ms,
            "peak_speed_over_datasheet": [round(float(v), 3) for v in speed.max(axis=0)],
            "last_over_first_second": [round(float(b / a), 3) if a > 0 else None for a, b in zip(first, last)],
            "holds": replica.health.holds}


def e1_with_late_ticks(seed: int, shortest: float = 0.02, longest: float = 0.048) -> dict[str, Any]:
    """The in-process E1 run (the circle, the operator, the channel; 9 s) with the replica's ticks drawn in
    [shortest, longest] apart from 2 to 8 s, on fresh states (fic_teleop_experiments.in_process.ReplicaStall)."""
    from fic_teleop_experiments.in_process import ReplicaStall, RunConfig, run

    result = run(RunConfig(duration=9.0, seed=seed, control_rate=500.0,
                           replica_stalls=(ReplicaStall(2.0, 8.0, shortest, longest),)))
    return {"e1_seed": seed, "intervals_ms": [shortest * 1e3, longest * 1e3],
            "fastest_joint_rad_s": round(result.joint_speed_max, 3),
            "error_max_mm": round(float(result.tracking_error.max()) * 1e3, 1), "holds": result.replica_holds,
            "robot_watchdog_engagements": result.robot_watchdog_engagements}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--periods", type=float, nargs="+", default=[0.002, 0.02, 0.035, 0.05])
    parser.add_argument("--kick", type=float, nargs=7, default=list(DEFAULT_KICK))
    parser.add_argument("--duration", type=float, default=4.0)
    parser.add_argument("--longest", type=float, default=None,
                        help="intervals drawn in [period, longest] [s] per tick (a starved replica's)")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1])
    parser.add_argument("--e1-seeds", type=int, nargs="+", default=[],
                        help="instead: the in-process E1 run with late ticks for these seeds")
    parser.add_argument("--set", nargs=2, action="append", default=[], metavar=("NAME", "VALUE"),
                        help="a replica parameter changed (yaml value), e.g. --set controller linear")
    args = parser.parse_args(argv)
    changes = {name: yaml.safe_load(value) for name, value in args.set}
    if args.e1_seeds:
        for seed in args.e1_seeds:
            print(json.dumps(e1_with_late_ticks(seed)), flush=True)
        return
    for period in args.periods:
        for seed in args.seeds:
            print(json.dumps({"seed": seed, **sampled_run(period, tuple(args.kick), args.duration, args.longest,
                                                          seed, **changes)}), flush=True)


if __name__ == "__main__":
    main()
