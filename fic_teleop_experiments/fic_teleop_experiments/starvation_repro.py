"""The starved-replica reproduction (docs/RESULTS.md "Starvation"): in-process E1 runs whose replica is starved in a
window (fic_teleop_experiments.in_process.ReplicaStall: ticks far apart, on old states, torques late), with and
without the replica's own loop check (fic_core.loop_health) and the robot's rule on the age of a torque's state.

    python -m fic_teleop_experiments.starvation_repro --seeds 1 2 --arms old new
    python -m fic_teleop_experiments.starvation_repro --stalls ticks2-4_age0-150 --seeds 1 2 \
        --arms old old_paper_law old_linear_bounded old_fresh_velocity old_dynamics_at_physics_rate robot_rule_only new

Each line: the arm ("old": no loop check, no robot rule, as before them; "new": config/*.yaml as they are; the
other "old_..." arms take one candidate mechanism out: the paper's law without the feedforward and friction terms,
the linear baseline without the FIC's phases and latch, the newest velocity with the old position, C qd + G of the
arm's own state at every physics step; "robot_rule_only": the robot's rule without the loop check), the stall,
the seed, the fastest joint over the run [rad/s], the largest tracking error [mm], the robot watchdog's engagements,
the torques the robot refused as computed on too old a state, the replica's holds, and the limit-violation ticks.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math

from fic_teleop_experiments.in_process import ReplicaStall, RunConfig, run

#: (name, stall) of the runaway's figures: ticks 15-170 ms apart on states 22-178 ms old, and harsher variants.
STALLS = {
    "gaps15-170_age0-150": ReplicaStall(4.0, 7.0, 0.015, 0.17, 0.0, 0.0, 0.0, 0.15),
    "gaps15-170_age20-160_delay0-20": ReplicaStall(4.0, 7.0, 0.015, 0.17, 0.0, 0.02, 0.02, 0.16),
    "gaps10-60_age20-180": ReplicaStall(4.0, 7.0, 0.01, 0.06, 0.0, 0.0, 0.02, 0.18),
    "gaps30-60_age40-60": ReplicaStall(4.0, 7.0, 0.03, 0.06, 0.0, 0.0, 0.04, 0.06),
    "ticks2-4_age0-150": ReplicaStall(4.0, 7.0, 0.002, 0.004, 0.0, 0.0, 0.0, 0.15),   # on time, old states only
    "gaps15-170_fresh": ReplicaStall(4.0, 7.0, 0.015, 0.17, 0.0, 0.0),                 # late, fresh states only
}
ARMS = ("old", "new", "old_paper_law", "old_linear_bounded", "old_fresh_velocity", "old_dynamics_at_physics_rate",
        "robot_rule_only")
OLD = {"loop_max_state_age": 10.0, "loop_max_tick_gap": 10.0}   # the loop check out of reach: the law as before


def one(arm: str, stall: str, seed: int, control_rate: float, duration: float) -> dict:
    window = STALLS[stall]
    overrides = {} if arm == "new" else dict(OLD)
    rule = None if arm in ("new", "robot_rule_only") else math.inf
    if arm == "old_paper_law":
        overrides["paper_law"] = True
    elif arm == "old_linear_bounded":
        overrides["controller"] = "linear_bounded"
    elif arm == "old_fresh_velocity":
        window = dataclasses.replace(window, stale_velocity=False)
    result = run(RunConfig(duration=duration, seed=seed, control_rate=control_rate, replica_stalls=(window,),
                           replica_overrides=overrides, robot_command_state_timeout=rule,
                           dynamics_at_physics_rate=arm == "old_dynamics_at_physics_rate"))
    return {"arm": arm, "stall": stall, "seed": seed, "control_rate": control_rate,
            "joint_speed_max": round(result.joint_speed_max, 2),
            "error_max_mm": round(float(result.tracking_error.max()) * 1e3, 1),
            "arm_kinetic_energy_max_j": round(float(result.arm_kinetic_energy.max()), 2),
            "robot_watchdog_engagements": result.robot_watchdog_engagements,
            "stale_torques_refused": result.stale_torques_refused, "replica_holds": result.replica_holds,
            "violation_ticks": result.limit_violations}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--arms", nargs="+", default=["old", "new"], choices=ARMS)
    parser.add_argument("--stalls", nargs="+", default=list(STALLS)[:4], choices=list(STALLS))
    parser.add_argument("--control-rate", type=float, default=500.0, help="the realtime graph's 500 Hz by default")
    parser.add_argument("--duration", type=float, default=9.0)
    args = parser.parse_args(argv)
    for stall in args.stalls:
        for seed in args.seeds:
            for arm in args.arms:
                print(json.dumps(one(arm, stall, seed, args.control_rate, args.duration)), flush=True)


if __name__ == "__main__":
    main()
