"""The paper's experiments E1-E4 (docs/EXPERIMENTS.md), run through the main job's launcher on the real graph.

    scripts/experiments.sh                      # everything, lockstep, results to results/
    scripts/experiments.sh --only E4            # one experiment (E1, E2, E3, E4; comma-separated)
    scripts/experiments.sh --quick              # 2 short E4 cells (the in-suite test), results to runs/.../results
    scripts/experiments.sh --time-mode realtime # wall-clock paced instead of lockstep

Every cell is one call of the launcher (fic_teleop_bringup.teleop_launcher, what scripts/run_teleop.sh runs): the whole
graph as real processes over DDS, recorded to an MCAP bag under --runs. Each cell is then analysed from its bag: the
report's metrics (fic_teleop_tools.report, computed in-process), the run verdict (fic_teleop_tools.verdict.run_verdict,
the one every run is judged by; a sweep cell runs at least as long as it needs to judge the cell's delay), and per
experiment:

- E1 superimposition at 200 ms: the default run (superimposition scene, scripted operator, 200 ms each way) with the
  report's plots.
- E2 shape sorting: the scene's default operator (sim_bridge.device.shape_sorting_operator: it looks, aligns and
  feels through the delay) picks each of the three pieces by the adhesive bond, inserts it, locks and pulls until the
  bond breaks, for its TRIAL_DURATION_S; trials with different seeds (the bond's break thresholds and the channel's
  draws); success = the piece ends inside the box (/sim/object_poses).
- E3 blackout: the E2 task with total communication loss from --e3-blackout-at on (during contact); energy, limit
  violations, forces and stability after the loss.
- E4 sweeps: one-way delay (both ways) at the full rate, and the rate (channel rate cap AND replica control rate)
  at zero delay, each with the FIC and the linear baseline of the same K0, haptic feedback on (the master's K_H).

Results: <results>/e1.json ... e4.json, summary.json, and PNG plots. Nothing here is a placeholder: every number
comes from a run's bag; a cell that failed says so (and why) in its JSON.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import shutil
import signal
import subprocess
import sys
import time
from datetime import datetime
from pathlib import Path

from tqdm import tqdm

from fic_teleop_experiments.cell_analysis import analyse_cell
from fic_teleop_experiments.plots import plot_e2_forces, plot_e3, plot_stability_map, plot_sweep
from fic_teleop_experiments.runner import CONTROLLERS, Cell, LaunchOutcome, launch, write_json
from fic_teleop_experiments.shape_sorting import PIECE_NAMES
from fic_teleop_experiments.tables import headline_of, markdown_tables
from fic_teleop_runtime.workspace import config_folder, working_folder
from fic_teleop_tools.verdict.run_verdict import VerdictCriterion
from sim_bridge.device.shape_sorting_operator import TRIAL_DURATION_S

REPO = working_folder()   # runs/ and results/ (FIC_TELEOP_ROOT, else the current folder)

DELAYS = (0.0, 0.1, 0.2, 0.5, 1.0, 2.0)
RATES = (1000.0, 250.0, 100.0, 50.0, 10.0)


# --- the cells ---------------------------------------------------------------------------------------------------
def sweep_duration(args, delay: float) -> float:
    """[s] an E4 cell's length: --sweep-duration, or longer where the run verdict needs more run to judge the periods
    a delay can make (VerdictCriterion.run_needed: 8 s at 0.2 s, 26 s at 2 s)."""
    return max(args.sweep_duration, VerdictCriterion().run_needed(delay))


def quiet_tail(delay: float) -> float:
    """[s] the quiet tail after a superimposition cell's task (the launcher's --quiet-tail): the planner stops, the
    operator's target holds still and the hand keeps holding the handle, and the run verdict judges STABLE by the
    loop's free response there (VerdictCriterion.tail_needed: a flush, then 4 round trips, at least 8 s), not by
    the driven swing of the task (docs/EXPERIMENTS.md, "The run verdict"). One second more than the verdict needs:
    the launcher stops the graph when the simulation reaches the end, and a recorder behind it under load had 8.7 s
    of a 9.4 s tail in its bag (2026-12-06), too short to judge."""
    return VerdictCriterion().tail_needed(delay) + 1.0


def e1_cells(args) -> list[Cell]:
    return [Cell("e1", "E1", {"scene": "superimposition", "duration": args.e1_duration, "delay": 0.2,
                              "quiet_tail": quiet_tail(0.2), "controller": "fic", "seed": 1}, report=True)]


def e2_cells(args) -> list[Cell]:
    # The E2 operator script's travel legs were tuned in closed loop against the paper's Eq. 7 (an in-process twin of
    # the graph);
    # --e2-law default runs the same script with the replica's default model terms (docs/EXPERIMENTS.md).
    return [Cell(f"e2_seed{seed}", "E2", {"scene": "shape_sorting", "trajectory": "fixed",
                                          "duration": args.e2_duration, "delay": 0.2, "seed": seed,
                                          "paper_law": args.e2_law == "paper"},
                 labels={"seed": seed}) for seed in range(1, args.e2_trials + 1)]


def e3_cells(args) -> list[Cell]:
    return [Cell("e3", "E3", {"scene": "shape_sorting", "trajectory": "fixed", "duration": args.e3_duration,
                              "delay": 0.2, "seed": 1, "blackout_at": args.e3_blackout_at,
                              "paper_law": args.e2_law == "paper"},
                 labels={"blackout_at": args.e3_blackout_at})]


def e4_cells(args) -> list[Cell]:
    cells = []
    # The rate sweep runs at zero delay; its 1000 Hz point IS the zero-delay cell of the delay sweep (a 1000 Hz rate
    # cap is above the master's 250 Hz network rate and the replica's default rate is 1000 Hz: the same run).
    full_rate = max(args.rates) >= 1000.0 and 0.0 in args.delays
    for delay in args.delays:
        for controller in CONTROLLERS:
            sweep = "delay+rate" if (delay == 0.0 and full_rate) else "delay"
            cells.append(Cell(f"e4_delay{delay:g}_{controller}", "E4",
                              {"scene": "superimposition", "duration": sweep_duration(args, delay), "delay": delay,
                               "quiet_tail": quiet_tail(delay), "controller": controller, "seed": 1},
                              labels={"sweep": sweep, "delay": delay, "rate": 1000.0, "controller": controller}))
    for rate in args.rates:
        if rate >= 1000.0 and full_rate:
            continue
        for controller in CONTROLLERS:
            cells.append(Cell(f"e4_rate{rate:g}_{controller}", "E4",
                              {"scene": "superimposition", "duration": sweep_duration(args, 0.0), "delay": 0.0,
                               "quiet_tail": quiet_tail(0.0), "rate_cap": rate, "control_rate": rate,
                               "controller": controller, "seed": 1},
                              labels={"sweep": "rate", "delay": 0.0, "rate": rate, "controller": controller}))
    return cells


def quick_cells(args) -> list[Cell]:
    return [Cell(f"e4_delay0.2_{controller}", "E4",
                 {"scene": "superimposition", "duration": sweep_duration(args, 0.2), "delay": 0.2,
                  "quiet_tail": quiet_tail(0.2), "controller": controller,
                  "seed": 1}, labels={"sweep": "delay", "delay": 0.2, "rate": 1000.0, "controller": controller})
            for controller in CONTROLLERS]


# --- driver ------------------------------------------------------------------------------------------------------
def outcome_from_log(run_dir: Path) -> LaunchOutcome:
    """The launch outcome of an existing run folder, from its launcher.log (for --reanalyse)."""
    import re

    text = (run_dir / "launcher.log").read_text(errors="replace")
    stopped = re.search(r"graph stopped after ([0-9.]+) s wall, ([0-9.]+) s simulated(.*)", text)
    previous = run_dir / "cell.json"
    code = json.loads(previous.read_text()).get("launcher_exit_code", 0) if previous.exists() else 0
    if not stopped:
        return LaunchOutcome(code, 0.0, 0.0, run_dir / "launcher.log", "launcher did not finish")
    return LaunchOutcome(code, float(stopped.group(1)), float(stopped.group(2)), run_dir / "launcher.log",
                         stopped.group(3).strip("; "))


def git_commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return ""


def replica_max_force() -> float | None:
    from fic_teleop_tools.report.report import replica_config_defaults

    return replica_config_defaults().get("max_force_n")


def parse_arguments(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--only", default="E1,E2,E3,E4", help="experiments to run, comma-separated (default all)")
    parser.add_argument("--quick", action="store_true",
                        help="two short E4 cells (FIC and linear at 200 ms, --sweep-duration 5 s unless given)")
    parser.add_argument("--time-mode", default="lockstep", choices=["lockstep", "realtime"])
    parser.add_argument("--results", type=Path, default=None,
                        help="results folder (default: results/, or <runs>/results with --quick)")
    parser.add_argument("--runs", type=Path, default=None, help="run folders with the bags (default "
                                                                "runs/experiments-<time>)")
    parser.add_argument("--e1-duration", type=float, default=30.0)
    parser.add_argument("--e2-duration", type=float, default=TRIAL_DURATION_S,
                        help="simulated s a trial (default: the shape-sorting operator's, the scene's default "
                             "operator)")
    parser.add_argument("--e2-trials", type=int, default=4)
    parser.add_argument("--e2-law", choices=["paper", "default"], default="paper",
                        help="E2 and E3: the replica law the operator script was tuned against (paper: Eq. 7 as "
                             "written, the launcher's --paper-law) or the default with its model terms")
    parser.add_argument("--e3-duration", type=float, default=None, help="default: blackout time + 12 s")
    parser.add_argument("--e3-blackout-at", type=float, default=None,
                        help="default: mid-press of the plate on the first piece (from the operator script)")
    parser.add_argument("--sweep-duration", type=float, default=None, help="E4 cell duration (default 20 s, 5 s quick)")
    parser.add_argument("--reanalyse", action="store_true",
                        help="do not run: analyse the run folders already in --runs again (e.g. after changing the "
                             "criterion) and rewrite the results")
    parser.add_argument("--tables", action="store_true",
                        help="only print the markdown tables of the results folder's eN.json (no runs)")
    parser.add_argument("--delays", type=float, nargs="+", default=list(DELAYS))
    parser.add_argument("--rates", type=float, nargs="+", default=list(RATES))
    args = parser.parse_args(argv)
    args.only = {name.strip().upper() for name in args.only.split(",") if name.strip()}
    if args.sweep_duration is None:
        args.sweep_duration = 5.0 if args.quick else 20.0
    stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
    if args.reanalyse and args.runs is None:
        parser.error("--reanalyse needs --runs")
    args.runs = args.runs or REPO / "runs" / f"experiments-{stamp}"
    args.results = args.results or (args.runs / "results" if args.quick else REPO / "results")
    script = shape_sorting_script_timing()
    if args.e3_blackout_at is None:
        args.e3_blackout_at = round(script["first_press_s"], 1)  # mid-press on the first piece: contact
    if args.e3_duration is None:
        args.e3_duration = round(args.e3_blackout_at + 12.0, 1)
    return args


def shape_sorting_script_timing() -> dict:
    """Length of the E2 operator script and the middle of its first press on a piece (for the E3 blackout)."""
    import yaml

    script = yaml.safe_load((config_folder() / "operator_scripts" / "shape_sorting.yaml").read_text())
    waypoints = script["waypoints"]
    length = float(waypoints[-1]["t"])
    parameters = script.get("parameters", {})
    # The first pick: the travel down to hover over the first piece ends (leg_ends), then the handle descends for
    # 2 ramps to press the plate on the piece and holds bond_time: the middle of that hold is contact.
    down = parameters.get("leg_ends",
                          {}).get(f"{parameters['pieces'][0]['name']}:down") if parameters.get("pieces") else None
    if down is None:
        raise SystemExit("the shape-sorting script has no leg_ends: regenerate it (python -m "
                         "sim_bridge.device.operator_scripts)")
    press = float(down[0]) + 2.0 * float(parameters["ramp"]) + 0.5 * float(parameters["bond_time"])
    return {"length_s": length, "first_press_s": press}


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    # Started in the background (nohup ... &) a process inherits SIGINT ignored, and so would the launcher and its
    # nodes, which are stopped with SIGINT: restore Ctrl-C, and let SIGTERM stop the running cell cleanly too.
    signal.signal(signal.SIGINT, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)
    args = parse_arguments(argv)
    if args.tables:
        print(markdown_tables(args.results))
        return 0
    criterion = VerdictCriterion()
    cells: list[Cell] = []
    if args.quick:
        cells = quick_cells(args)
    else:
        for name, make in (("E1", e1_cells), ("E2", e2_cells), ("E3", e3_cells), ("E4", e4_cells)):
            if name in args.only:
                cells += make(args)
    if not cells:
        print("[experiments] nothing to run", file=sys.stderr)
        return 2
    args.results.mkdir(parents=True, exist_ok=True)
    args.runs.mkdir(parents=True, exist_ok=True)
    total = sum(cell.simulated for cell in cells)
    print(f"[experiments] {len(cells)} runs, {total:.0f} s simulated, {args.time_mode}; bags in {args.runs}; "
          f"results in {args.results}", flush=True)
    results: dict[str, list[tuple[dict, Path]]] = {}
    started = time.monotonic()
    bar = tqdm(total=round(total, 1), unit="sim s", dynamic_ncols=True, file=sys.stdout,
               bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} sim s [{elapsed}<{remaining}] {postfix}")
    done = 0.0
    try:
        for index, cell in enumerate(cells):
            run_dir = args.runs / cell.id
            bar.set_postfix_str(f"{index + 1}/{len(cells)} {cell.id}")

            def progress(simulated: float, base=done, limit=cell.simulated) -> None:
                bar.n = round(base + min(simulated, limit), 1)
                bar.refresh()

            if args.reanalyse:
                if not (run_dir / "launcher.log").exists():
                    tqdm.write(f"[experiments] {cell.id}: no run in {run_dir}, skipped")
                    continue
                outcome = outcome_from_log(run_dir)
            else:
                if run_dir.exists():
                    shutil.rmtree(run_dir)
                outcome = launch(cell, run_dir, time_mode=args.time_mode, on_progress=progress)
            done += cell.simulated
            bar.n = round(done, 1)
            bar.refresh()
            blackout = cell.options.get("blackout_at")
            result = analyse_cell(cell, run_dir, outcome, blackout_at=blackout)
            write_json(run_dir / "cell.json", result)
            results.setdefault(cell.experiment, []).append((result, run_dir))
            verdict = result.get("stability", {}).get("stable")
            tqdm.write(f"[experiments] {cell.id}: {'stable' if verdict else 'UNSTABLE' if verdict is False else 'n/a'}"
                       ", max error (last half) "
                       f"{result.get('stability', {}).get('max_error_last_half', float('nan')):.4f} m"
                       f", violations {result.get('limits', {}).get('violation_ticks')}, wall {outcome.wall_s:.0f} s"
                       + ("" if result.get("complete") else f" (ran {outcome.simulated_s:.1f} s of "
                                                             f"{cell.simulated:g} s)"), file=sys.stdout)
    except KeyboardInterrupt:
        tqdm.write("[experiments] interrupted: writing what has run")
    finally:
        bar.close()
    summary = write_results(args, results, criterion, time.monotonic() - started)
    print(json.dumps(summary["headline"], indent=2))
    print(f"[experiments] results in {args.results}")
    return 0


def write_results(args, results: dict[str, list[tuple[dict, Path]]], criterion: VerdictCriterion, wall: float) -> dict:
    out = args.results
    stamp = {"generated": datetime.now().isoformat(timespec="seconds"), "git_commit": git_commit(),
             "time_mode": args.time_mode, "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]])}
    max_force = replica_max_force()
    if "E1" in results:
        result, run_dir = results["E1"][0]
        for name in ("tracking_error.png", "position.png", "interaction_force.png", "paths_3d.png"):
            source = run_dir / "report" / name
            if source.exists():
                shutil.copy(source, out / f"e1_{name}")
        write_json(out / "e1.json", {**stamp, **result})
    if "E2" in results:
        trials = [r for r, _ in results["E2"]]
        inside = [t.get("pieces_inside") for t in trials]
        forces = [t.get("peak_force_n") for t in trials if t.get("peak_force_n") is not None]
        e2 = {**stamp, "trials": trials, "pieces_per_trial": len(PIECE_NAMES),
              "pieces_inside_per_trial": inside,
              "successful_trials": sum(1 for n in inside if n == len(PIECE_NAMES)),
              "pieces_inside_total": sum(n for n in inside if n is not None),
              "peak_force_n_max": max(forces) if forces else None,
              "replica_max_force_n": max_force,
              "stable_trials": sum(1 for t in trials if t.get("stability", {}).get("stable")),
              "violation_ticks_total": sum(t.get("limits", {}).get("violation_ticks") or 0 for t in trials)}
        write_json(out / "e2.json", e2)
        plot_e2_forces(results["E2"], out, max_force)
    if "E3" in results:
        result, run_dir = results["E3"][0]
        write_json(out / "e3.json", {**stamp, **result})
        plot_e3(result, run_dir, out)
    if "E4" in results:
        cells = [r for r, _ in results["E4"]]
        e4 = {**stamp, "cells": cells, "criterion": dataclasses.asdict(criterion),
              "table": [{"id": c["id"], **c["labels"], "stable": c.get("stability", {}).get("stable"),
                         "max_error_last_half_m": c.get("stability", {}).get("max_error_last_half"),
                         "max_error_m": c.get("stability", {}).get("max_error"),
                         "free_motion_error_max_m": c.get("metrics", {}).get("free_motion_error_max_m"),
                         "contact_error_max_m": c.get("metrics", {}).get("contact_error_max_m"),
                         "violation_ticks": c.get("limits", {}).get("violation_ticks"),
                         "shaped_ticks": c.get("limits", {}).get("shaped_ticks"),
                         "peak_force_n": c.get("peak_force_n"),
                         "reasons": c.get("stability", {}).get("reasons"),
                         "complete": c.get("complete"), "wall_s": c.get("wall_s")} for c in cells]}
        write_json(out / "e4.json", e4)
        plot_sweep(cells, "delay", out)
        plot_sweep(cells, "rate", out)
        plot_stability_map(cells, out)
    # The summary is composed from every eN.json in the folder, so experiments run by separate invocations
    # (--only E4, then --only E2) all appear in it; each keeps its own "generated" stamp.
    experiments = {}
    for name in ("E1", "E2", "E3", "E4"):
        path = out / f"{name.lower()}.json"
        if path.exists():
            data = json.loads(path.read_text())
            experiments[name] = {"generated": data.get("generated"), "time_mode": data.get("time_mode"),
                                 "headline": headline_of(name, data)}
            if name == "E4":
                experiments[name]["table"] = data.get("table")
    summary = {**stamp, "quick": args.quick, "wall_s_of_this_invocation": round(wall, 1), "runs": str(args.runs),
               "machine": {"cpus": os.cpu_count(), "load_average": list(os.getloadavg()),
                           "python": platform.python_version()},
               "run_verdict_criterion": dataclasses.asdict(criterion), "experiments": experiments,
               "headline": {name: value["headline"] for name, value in experiments.items()}}
    write_json(out / "summary.json", summary)
    (out / "tables.md").write_text(markdown_tables(out) + "\n")
    return summary


if __name__ == "__main__":
    sys.exit(main())
