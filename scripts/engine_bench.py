#!/usr/bin/env python3
"""Runs per hour of the sweep engines on this machine (sim_bridge.experiments.engine_bench): the same job set through
the process pool and through a Dask LocalCluster, in alternating rounds. Writes a JSON with the command, the
machine's load and every round (docs/CLUSTER.md; docs/EXPERIMENTS.md "The engines' runs per hour").

    nice -n 5 .venv/bin/python scripts/engine_bench.py --runs 24 --duration 10 --rounds 2
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from datetime import datetime, timezone
from pathlib import Path

from sim_bridge.experiments.engine import ENGINES, local_cores
from sim_bridge.experiments.engine_bench import alternating_rounds, jobs

REPO = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=24, help="jobs a round")
    parser.add_argument("--duration", type=float, default=10.0, help="simulated seconds a run")
    parser.add_argument("--rounds", type=int, default=2, help="rounds of each engine, alternating")
    parser.add_argument("--workers", type=int, default=None, help=f"default: every core ({local_cores()})")
    parser.add_argument("--engines", nargs="+", default=list(ENGINES), choices=ENGINES)
    parser.add_argument("--out", type=Path, default=REPO / "results" / "engine_bench.json")
    args = parser.parse_args(argv)

    def report(row: dict) -> None:
        print(f"round {row['round']} {row['engine']:>4}: {row['runs']} runs in {row['wall_s']:.1f} s "
              f"({row['runs_per_hour']:.0f} runs/h; engine start {row['engine_start_s']:.1f} s; "
              f"load {row['load_1min_before']:.1f} -> {row['load_1min_after']:.1f})", flush=True)

    rounds, summary = alternating_rounds(args.engines, args.workers or local_cores(), jobs(args.runs, args.duration),
                                         args.rounds, report)
    arguments = sys.argv[1:] if argv is None else argv
    document = dict(command="nice -n 5 .venv/bin/python scripts/engine_bench.py " + " ".join(arguments),
                    date_utc=datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M"), machine=platform.node(),
                    cores=local_cores(), niceness=os.nice(0), duration_s=args.duration, runs_per_round=args.runs,
                    summary=summary, rounds=rounds)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(document, indent=1) + "\n")
    for engine, figures in summary.items():
        print(f"{engine:>4}: {figures['total_runs_per_hour']:.0f} runs/h over all rounds "
              f"({', '.join(f'{value:.0f}' for value in figures['runs_per_hour'])})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
