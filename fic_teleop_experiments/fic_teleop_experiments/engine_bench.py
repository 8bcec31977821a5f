"""Runs per hour of the sweep engines (fic_teleop_experiments.engine) on one machine: the same job set through the
process pool and through a Dask LocalCluster, in alternating rounds so that both see the same machine load.
Writes a JSON with the command, the machine's load and every round (docs/CLUSTER.md; the figures: docs/RESULTS.md
"The verdict and the engines").

    nice -n 5 python -m fic_teleop_experiments.engine_bench --runs 24 --duration 10 --rounds 2

The jobs are claim runs (fic_teleop_experiments.claims.ClaimRun) at 1 s one-way delay and full rate, the reactive
hand, each law in turn, each judged by the run verdict: a sweep's unit of work, returning a small row.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

from fic_teleop_experiments.claims import CONTROLLERS, ClaimRun
from fic_teleop_experiments.engine import ENGINES, local_cores, open_engine
from fic_teleop_experiments.in_process import run
from fic_teleop_runtime.workspace import working_folder
from fic_teleop_tools.verdict.run_verdict import VerdictInput, judge

REPO = working_folder()   # runs/ and results/ (FIC_TELEOP_ROOT, else the current folder)


def jobs(runs: int, duration: float) -> list[ClaimRun]:
    """``runs`` jobs: the laws in turn, seeds 1, 2, ..."""
    return [ClaimRun(delay=1.0, rate_hz=0.0, controller=CONTROLLERS[i % len(CONTROLLERS)], hand="reactive",
                     seed=1 + i // len(CONTROLLERS), duration=duration) for i in range(runs)]


def simulated_and_judged(claim: ClaimRun) -> dict:
    """One job: the run simulated, then judged (its series are not kept)."""
    result = run(claim.config())
    verdict = judge(VerdictInput.from_run_result(result, one_way_delay=claim.delay))
    return dict(simulated_s=result.simulated_s, wall_s=result.wall_s, stable=verdict.stable)


def one_round(engine: str, workers: int, job_set: list[ClaimRun]) -> dict:
    """One engine opened, the job set run through it, closed: wall time with the engine's start, runs per hour,
    and the runs' own simulation wall time summed (what the engine's overhead is not)."""
    load_before = os.getloadavg()[0]
    start = time.perf_counter()
    with open_engine(workers=workers, engine=engine) as opened:
        opened_s = time.perf_counter() - start
        rows = list(opened.executor.map(simulated_and_judged, job_set))
    wall = time.perf_counter() - start
    return dict(engine=engine, workers=workers, runs=len(rows), wall_s=wall, engine_start_s=opened_s,
                runs_per_hour=3600.0 * len(rows) / wall, simulated_s=sum(r["simulated_s"] for r in rows),
                runs_wall_s_sum=sum(r["wall_s"] for r in rows), load_1min_before=load_before,
                load_1min_after=os.getloadavg()[0], stable=sum(1 for r in rows if r["stable"]))


def alternating_rounds(engines: list[str], workers: int, job_set: list[ClaimRun], rounds: int,
                       report=None) -> tuple[list[dict], dict]:
    """``rounds`` rounds of every engine in turn; (every round, per engine its runs per hour over all rounds)."""
    done = []
    for index in range(rounds):
        for engine in engines:
            row = {"round": index + 1, **one_round(engine, workers, job_set)}
            done.append(row)
            if report is not None:
                report(row)
    summary = {engine: dict(runs_per_hour=[r["runs_per_hour"] for r in done if r["engine"] == engine],
                            total_runs_per_hour=3600.0 * sum(r["runs"] for r in done if r["engine"] == engine)
                            / sum(r["wall_s"] for r in done if r["engine"] == engine))
               for engine in engines}
    return done, summary


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
    document = dict(command="nice -n 5 python -m fic_teleop_experiments.engine_bench " + " ".join(arguments),
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
