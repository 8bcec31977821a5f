#!/usr/bin/env python3
"""One lockstep graph run and the same configuration in process: the channel ports' figures side by side
(sim_bridge.experiments.graph_passivity; docs/RESULTS.md, "Passivity in the graph").

    python scripts/graph_passivity.py --controller linear_tdpa --delay 1.0 --duration 8 --out /tmp/gp
    python scripts/graph_passivity.py --controller fic --tdpa --delay 1.0 --duration 8 --out /tmp/gp_fic
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--controller", default="linear_tdpa", choices=["fic", "linear_bounded", "linear_tdpa"])
    parser.add_argument("--tdpa", action="store_true", help="TDPA around the law (linear_tdpa has it already)")
    parser.add_argument("--delay", type=float, default=1.0)
    parser.add_argument("--duration", type=float, default=8.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=Path, required=True, help="the graph run's folder (must not exist)")
    args = parser.parse_args()
    launch = [sys.executable, str(REPO / "scripts" / "teleop_launcher.py"), "--out", str(args.out),
              "--duration", str(args.duration), "--delay", str(args.delay), "--seed", str(args.seed),
              "--controller", args.controller, "--time-mode", "lockstep", "--no-video", "--wall-limit", "1800",
              *(["--tdpa"] if args.tdpa else [])]
    graph = subprocess.run(launch, capture_output=True, text=True)
    if graph.returncode != 0:
        print(graph.stdout[-2000:] + graph.stderr[-2000:], file=sys.stderr)
        print(f"the graph run failed (exit {graph.returncode}); its folder: {args.out}", file=sys.stderr)
        return 1
    from sim_bridge.experiments.graph_passivity import compare
    from sim_bridge.experiments.in_process import RunConfig

    config = RunConfig(duration=args.duration, delay=args.delay, controller=args.controller, seed=args.seed,
                       tdpa=args.tdpa)
    print(json.dumps(dataclasses.asdict(compare(args.out, config)), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
