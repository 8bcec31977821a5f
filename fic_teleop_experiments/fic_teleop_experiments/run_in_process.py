"""Run the teleoperation graph in one process (fic_teleop_experiments.in_process): the same core objects the nodes
wrap, no DDS. Prints the tracking error, the limit counters and the speed (simulated seconds per wall second and
per CPU second of this process).

    python -m fic_teleop_experiments.run_in_process [--scene superimposition] [--duration 10] [--delay 0.2] [--runs 3]
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from fic_teleop_experiments.in_process import RunConfig, run


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scene", default="superimposition", choices=["superimposition", "shape_sorting",
                                                                       "free_space"])
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--delay", type=float, default=0.2)
    parser.add_argument("--jitter", type=float, default=0.0)
    parser.add_argument("--drop", type=float, default=0.0)
    parser.add_argument("--rate-cap", type=float, default=0.0)
    parser.add_argument("--blackout-window", type=float, nargs=2, action="append", default=[])
    parser.add_argument("--controller", default="fic", choices=["fic", "linear", "linear_bounded"])
    parser.add_argument("--control-rate", type=float, default=1000.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--handle-extrapolation", type=float, default=None,
                        help="the master's handle_extrapolation [s] (default: config/master.yaml's)")
    parser.add_argument("--runs", type=int, default=1, help="repeat the run (speed figures; results must agree)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    config = RunConfig(scene=args.scene, duration=args.duration, delay=args.delay, jitter=args.jitter, drop=args.drop,
                       blackout_windows=tuple(tuple(w) for w in args.blackout_window), rate_cap=args.rate_cap,
                       controller=args.controller, control_rate=args.control_rate, seed=args.seed,
                       master_overrides={} if args.handle_extrapolation is None
                       else {"handle_extrapolation": args.handle_extrapolation})
    rows = []
    for _ in range(args.runs):
        cpu = time.process_time()
        result = run(config)
        cpu = time.process_time() - cpu
        error = result.tracking_error[result.time >= 2.0] if result.time[-1] > 2.0 else result.tracking_error
        rows.append({"error_max_m": float(error.max()), "error_rms_m": float(np.sqrt(np.mean(error ** 2))),
                     "peak_force_n": float(np.linalg.norm(result.force, axis=1).max()),
                     "limit_violations": result.limit_violations, "shaped_ticks": result.shaped_ticks,
                     "sim_per_wall_s": result.speed, "sim_per_cpu_s": result.simulated_s / cpu})
    if args.json:
        print(json.dumps(rows, indent=2))
    else:
        for row in rows:
            print("  ".join(f"{key} {value:.4g}" for key, value in row.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
