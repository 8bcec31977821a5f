"""Whole main jobs of several checkouts or launcher options, taken in turn (docs/EXPERIMENTS.md, "Benchmarks").

    scripts/bench.sh --versus OLD=/path/to/clone NEW=. [GROUPED=.:"--group robot,replica"] --runs 4

This VM's speed drifts by up to 2x within hours, so two arms measured an hour apart say little about each other.
Each round runs every arm once, in the order given, so that a drift falls on all of them alike. An arm is
``NAME=DIR[:LAUNCHER ARGS]``: DIR is a checkout set up by its own ``scripts/setup.sh`` (``.``: this one); each run is
``DIR/scripts/run_teleop.sh --no-video --out RUN ARGS``, started from DIR, so an older commit runs its own code and
config. Per run: the whole process tree's CPU-s (user + system of every descendant, as the kernel counts them when
they are reaped), wall time, the load average, the exit code, and from the run's report (read by this checkout's
readers, so every arm is measured alike) the latency p99, the free-motion error, the slowest loop and its rate.
"""
from __future__ import annotations

import argparse
import shlex
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fic_teleop_experiments.runner import write_json
from fic_teleop_experiments.tools.bench import MAIN_JOB, default_run


@dataclass(frozen=True)
class Arm:
    name: str
    checkout: Path
    launcher_args: tuple[str, ...]


def parse_arm(text: str, here: Path) -> Arm:
    """``NAME=DIR[:LAUNCHER ARGS]`` (DIR ``.`` is this checkout); refused in one line if DIR is not a checkout."""
    name, separator, spec = text.partition("=")
    if not separator or not name or not spec:
        raise argparse.ArgumentTypeError(f"--versus takes NAME=DIR[:LAUNCHER ARGS], not {text!r}")
    directory, _, args = spec.partition(":")
    checkout = here if directory == "." else Path(directory).expanduser().resolve()
    if not (checkout / "scripts" / "run_teleop.sh").is_file():
        raise argparse.ArgumentTypeError(f"--versus {name}: {checkout} has no scripts/run_teleop.sh (not a checkout)")
    return Arm(name, checkout, tuple(shlex.split(args)))


def one_run(arm: Arm, run_dir: Path, log_path: Path) -> dict:
    """One main job of ``arm`` (bench.default_run from the arm's checkout, without the graph census) and its line's
    figures."""
    run = default_run(run_dir, log_path, ["--no-video", *arm.launcher_args], checkout=arm.checkout, census=False)
    metrics = run["metrics"]
    known = {name: row["fraction"] for name, row in run["loop_rates"].items() if row["fraction"] is not None}
    slowest = min(known, key=known.get) if known else None
    return {"arm": arm.name, "exit_code": run["exit_code"], "cpu_s": run["nodes"][MAIN_JOB]["cpu_s"],
            "wall_s": run["wall_s"], "load_average_before": round(run["load_average_before"][0], 2),
            "pipeline_latency_p99_ms": run["pipeline_latency_p99_ms"],
            "free_motion_error_max_mm": _millimetres(metrics.get("free_motion_error_max_m")),
            "free_motion_error_rms_mm": _millimetres(metrics.get("free_motion_error_rms_m")),
            "slowest_loop": slowest, "slowest_loop_fraction": known.get(slowest), "run_dir": str(run_dir),
            "nodes": run["nodes"]}


def _millimetres(metres: float | None) -> float | None:
    return None if metres is None else round(1e3 * metres, 1)


def arm_summary(runs: list[dict]) -> dict:
    """Per arm: exit 0 in how many, and min / median / max of CPU-s, p99 and the slowest loop."""
    def spread(key: str) -> list | None:
        values = [run[key] for run in runs if run[key] is not None]
        return [round(float(f(values)), 3) for f in (np.min, np.median, np.max)] if values else None

    return {"runs": len(runs), "exit_0": sum(run["exit_code"] == 0 for run in runs),
            "cpu_s": spread("cpu_s"), "pipeline_latency_p99_ms": spread("pipeline_latency_p99_ms"),
            "slowest_loop_fraction": spread("slowest_loop_fraction"),
            "free_motion_error_max_mm": spread("free_motion_error_max_mm"),
            "free_motion_error_rms_mm": spread("free_motion_error_rms_mm")}


def line(run: dict, round_index: int) -> str:
    p99, loop = run["pipeline_latency_p99_ms"], run["slowest_loop_fraction"]
    return (f"{run['arm']} {round_index} exit {run['exit_code']} cpu {run['cpu_s']:.2f} wall {run['wall_s']:.1f} "
            f"load {run['load_average_before']:.2f} p99 {'n/a' if p99 is None else f'{p99:.2f}'} "
            f"err_max {run['free_motion_error_max_mm']} rms {run['free_motion_error_rms_mm']}; slowest loop "
            f"{run['slowest_loop']} at {'n/a' if loop is None else f'{loop:.3f}'}")


def versus(arms: list[Arm], rounds: int, runs_dir: Path, out: Path) -> int:
    """``rounds`` rounds of every arm in turn; every run's line printed as it ends, the result rewritten to ``out``
    after each run (an interrupted bench keeps what it measured). Returns 0 when every run exited 0, else 1."""
    result: dict = {"arms": {arm.name: {"checkout": str(arm.checkout), "launcher_args": list(arm.launcher_args)}
                             for arm in arms}, "rounds": rounds, "runs": []}
    runs_dir.mkdir(parents=True, exist_ok=True)
    for round_index in range(1, rounds + 1):
        for arm in arms:
            name = f"{arm.name}-{round_index}"
            run = one_run(arm, runs_dir / name, runs_dir / f"{name}.log")
            result["runs"].append(run)
            print(line(run, round_index), flush=True)
            result["summary"] = {a.name: arm_summary([r for r in result["runs"] if r["arm"] == a.name])
                                 for a in arms}
            write_json(out, result)
    for name, totals in result["summary"].items():
        print(f"{name}: exit 0 in {totals['exit_0']} of {totals['runs']}; CPU-s {totals['cpu_s']}, p99 ms "
              f"{totals['pipeline_latency_p99_ms']}, slowest loop {totals['slowest_loop_fraction']} (min/median/max)")
    return 0 if all(run["exit_code"] == 0 for run in result["runs"]) else 1
