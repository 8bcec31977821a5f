"""E2 (shape sorting) trials on the DDS graph: the launcher in lockstep with the shape-sorting operator (the scene's
default, --operator shape-sorting), one run a seed, judged as e2.trial judges the runner's trials.

Resumable: each finished trial is one line of the jsonl (--out); a rerun skips the seeds already there. Per trial:
the pieces inside the box (the robot's ground truth, fic_teleop_experiments.shape_sorting), the operator's phases,
retries and time per piece (from the device node's log), the peak force and the time above F_max (the replica's
F/T force in the bag), limit violations, and the run's stable and safe verdicts (the report's verdict.json).
The seed sets the channel's jitter draws and the bonds' break thresholds; the operator and its hand are the same in
every graph trial (the in-process runner also varies those by seed).

    source scripts/env.sh
    nice -n 5 python -m fic_teleop_experiments.e2 graph --out results/e2_graph.jsonl --seeds 1 2 3 4
    python -m fic_teleop_experiments.e2 graph --out results/e2_graph.jsonl --summary -
    # the docs' tables: every graph law in one (the sweep's columns), and graph against the runner seed by seed
    python -m fic_teleop_experiments.e2 graph --table results/e2_graph_fic.jsonl results/e2_graph_stamped.jsonl \
        results/e2_graph_linear.jsonl
    python -m fic_teleop_experiments.e2 graph --agreement results/e2_sweep.jsonl \
        --table results/e2_graph_fic.jsonl results/e2_graph_linear.jsonl

--controller picks the replica's law (config/replica.yaml's ``controller``: fic, or a baseline with the same
stiffness), --paper-law the FIC's Eq. 7 as the paper writes it.
"""
from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from fic_teleop_experiments.cell_statistics import wilson_interval
from fic_teleop_experiments.shape_sorting import PIECE_NAMES, piece_outcomes
from sim_bridge.device.shape_sorting_operator import TRIAL_DURATION_S

from .jsonl import append_row, close_cut_line, read_rows
from .outcome import FORCE_OF_NOTE_N, operator_outcome

PHASE = re.compile(r"shape-sorting operator: (\w+:\w+) at ([\d.]+) s \(([-\d.e+naif]+)\)")


def run_trial(seed: int, delay: float, controller: str, paper_law: bool, duration: float, runs_dir: Path,
              wall_limit: float) -> dict:
    out = runs_dir / f"{controller}{'_paper_law' if paper_law else ''}_{delay:g}_seed{seed}"
    command = [sys.executable, "-m", "fic_teleop_bringup.teleop_launcher", "--scene", "shape_sorting",
               "--operator", "shape-sorting", "--time-mode", "lockstep", "--delay", str(delay), "--controller",
               controller, "--seed", str(seed), "--duration", str(duration), "--no-video", "--out", str(out),
               "--wall-limit", str(wall_limit), *(["--paper-law"] if paper_law else [])]
    started = time.monotonic()
    process = subprocess.run(command, capture_output=True, text=True)
    wall = time.monotonic() - started
    (runs_dir / f"{out.name}.launcher.log").write_text(process.stdout + process.stderr)
    return judge_run(out, seed, delay, controller, paper_law, process.returncode, wall)


def judge_run(out: Path, seed: int, delay: float, controller: str, paper_law: bool, returncode: int,
              wall: float) -> dict:
    from fic_teleop_tools.verdict.bag_series import read_run

    row = {"law": controller + ("_paper_law" if paper_law else ""), "delay_s": delay, "seed": seed,
           "launcher_exit_code": returncode, "wall_s": round(wall, 1), "run_dir": str(out)}
    series = read_run(out / "bag")
    outcomes = piece_outcomes(series)
    row["pieces_inside"] = [outcome.name for outcome in outcomes if outcome.inside]
    force = np.linalg.norm(series.force, axis=1) if series.force.size else np.zeros(1)
    times = series.wrench_time if series.force.size else np.zeros(1)
    step = float(np.median(np.diff(times))) if times.size > 1 else 0.0
    row["simulated_s"] = round(float(times[-1]), 1)
    row["peak_force_n"] = round(float(force.max()), 1)
    row["time_above_f_max_s"] = round(float((force > FORCE_OF_NOTE_N).sum() * step), 2)
    robot = series.diagnostics.get("robot_sim", {})
    row["bonds"] = {key: robot.get(key) for key in ("bonds_formed", "bond_breaks")}
    metrics_path, verdict_path = out / "report" / "metrics.json", out / "report" / "verdict.json"
    metrics = json.loads(metrics_path.read_text()) if metrics_path.exists() else {}
    row["limit_violations"] = metrics.get("limit_violations")
    verdict = json.loads(verdict_path.read_text()) if verdict_path.exists() else {}
    row["verdict"] = {key: verdict.get(key) for key in ("stable", "safe", "stable_reasons", "safe_reasons")}
    row["stale_holds"], row["wall_pace"] = stale_holds(out), pace(out)
    log_path = out / "logs" / "haptic_device.log"
    moves = [(label, float(start), float(value)) for label, start, value in
             PHASE.findall(log_path.read_text())] if log_path.exists() else []
    row["pieces"] = operator_outcome(moves, force, times)
    finished = [piece["end_s"] for piece in row["pieces"].values() if piece["end_s"] is not None]
    row["task_time_s"] = round(max(finished), 2) if len(finished) == len(PIECE_NAMES) else None
    row["retries"] = sum(piece["retries"] for piece in row["pieces"].values())
    decimate = max(1, int(round(0.1 / step))) if step > 0 else 1
    row["trace"] = {"time": np.round(times[::decimate], 3).tolist(), "force_n": np.round(force[::decimate], 2).tolist(),
                    "phases": [(label, round(start, 2)) for label, start, _ in moves]}
    return row


NAMED_STATE = re.compile(rb"joints@state_stamp_ns=(\d+)")
HOLD = re.compile(r"\[(\d+\.\d+)\] \[robot\]: watchdog: torque commands stale \(([\d.]+) s > ([\d.]+) s\)")


def stale_holds(out: Path) -> list[dict]:
    """Each stale-command hold of the robot in a lockstep run, with the clocks around it: the simulated time, the
    wall time the simulation took for the watchdog's bound (command_timeout, simulated) before it, and how many
    torque commands the replica published in that span (the bag's receive times). In lockstep the robot waits for
    each state's answer at most lockstep_timeout of wall time and then steps on the last command; so a hold means
    one bound's worth of consecutive steps whose answers came later than that in wall time. Answers published in
    the span say the replica was computing its law, late: the machine's scheduling, not the law's silence. And the
    state the newest of them was computed on (the stamp each command names, fic_core.command_stamp): its age at the
    hold in simulated ms (``newest_state_age_ms``, None when the commands name none) is what the watchdog should
    have seen; the robot before it matched answers to states by count, and took prompt answers for late ones."""
    from mcap.reader import make_reader

    log_path, bags = out / "logs" / "robot.log", sorted((out / "bag").glob("*.mcap"))
    if not log_path.exists() or not bags:
        return []
    holds = [(float(wall), float(bound)) for wall, _, bound in HOLD.findall(log_path.read_text())]
    if not holds:
        return []
    clock_wall, clock_sim, command_wall, command_state = [], [], [], []
    with bags[0].open("rb") as handle:
        for _, channel, message in make_reader(handle).iter_messages(topics=["/clock",
                                                                             "/effort_controller/commands"]):
            if channel.topic == "/clock":   # rosgraph_msgs/Clock in CDR: a 4-byte header, int32 sec, uint32 nanosec
                data = message.data
                clock_sim.append(int.from_bytes(data[4:8], "little", signed=True)
                                 + int.from_bytes(data[8:12], "little") * 1e-9)
                clock_wall.append(message.log_time * 1e-9)
            else:
                command_wall.append(message.log_time * 1e-9)
                named = NAMED_STATE.search(message.data)   # the layout label, read from the CDR bytes
                command_state.append(int(named.group(1)) * 1e-9 if named else np.nan)
    order = np.argsort(clock_wall)
    wall, simulated = np.asarray(clock_wall)[order], np.asarray(clock_sim)[order]
    by_arrival = np.argsort(command_wall)
    commands, states = np.asarray(command_wall)[by_arrival], np.asarray(command_state, dtype=float)[by_arrival]
    rows = []
    for at_wall, bound in holds:
        at = float(np.interp(at_wall, wall, simulated))
        began = float(np.interp(at - bound, simulated, wall))
        before = states[commands <= at_wall]
        before = before[np.isfinite(before)]
        rows.append({"t_s": round(at, 3), "wall_s_for_bound": round(at_wall - began, 2),
                     "commands_in_bound": int(((commands > began) & (commands <= at_wall)).sum()),
                     "newest_state_age_ms": round((at - float(before.max())) * 1e3, 1) if before.size else None})
    return rows


def pace(out: Path) -> dict:
    """The run's wall seconds per simulated millisecond (the bag's /clock: first to last receive time over the
    simulated span; the recorder takes messages in bursts, so single steps are not timed), and the steps the
    robot took without its answer (lockstep_timeouts, its last diagnostics)."""
    from mcap.reader import make_reader

    bags = sorted((out / "bag").glob("*.mcap"))
    if not bags:
        return {}
    with bags[0].open("rb") as handle:
        stamps = [message.log_time * 1e-9 for _, _, message in make_reader(handle).iter_messages(topics=["/clock"])]
    if len(stamps) < 2:
        return {}
    figures = {"wall_ms_per_simulated_ms": round((max(stamps) - min(stamps)) / (len(stamps) - 1) * 1e3, 1)}
    log_path = out / "logs" / "robot.log"
    found = re.search(r"'lockstep_timeouts': '(\d+)'", log_path.read_text()) if log_path.exists() else None
    if found:
        figures["lockstep_timeouts"] = int(found.group(1))
    return figures


def summary(rows: list[dict]) -> str:
    by_cell: dict[tuple[str, float], list[dict]] = {}
    for row in rows:
        by_cell.setdefault((row["law"], row["delay_s"]), []).append(row)
    lines = []
    for (law, delay), trials in sorted(by_cell.items()):
        n = len(trials)
        complete = sum(len(row["pieces_inside"]) == len(PIECE_NAMES) for row in trials)
        pieces = sum(len(row["pieces_inside"]) for row in trials)
        low, high = wilson_interval(complete, n)
        piece_low, piece_high = wilson_interval(pieces, n * len(PIECE_NAMES))
        durations = [piece["duration_s"] for row in trials for piece in row["pieces"].values()
                     if piece["result"] == "inside"]
        stable = [row["verdict"]["stable"] for row in trials if row["verdict"].get("stable") is not None]
        safe = [row["verdict"]["safe"] for row in trials if row["verdict"].get("safe") is not None]
        lines.append(f"{law} @ {delay:g} s: {complete}/{n} trials complete ({low:.2f}-{high:.2f}), {pieces}/"
                     f"{n * len(PIECE_NAMES)} pieces inside ({piece_low:.2f}-{piece_high:.2f}), "
                     f"{(sum(durations) / len(durations)) if durations else float('nan'):.1f} s a piece inside, "
                     f"peak force {[row['peak_force_n'] for row in trials]} N, above {FORCE_OF_NOTE_N:g} N "
                     f"{[row['time_above_f_max_s'] for row in trials]} s, retries "
                     f"{sum(row['retries'] for row in trials)}, limit violations "
                     f"{sum(row['limit_violations'] or 0 for row in trials)}, stable {sum(stable)}/"
                     f"{len(stable)}, safe {sum(safe)}/{len(safe)}")
    return "\n".join(lines) + "\n"


def piece_times(row: dict) -> str:
    """The range of the time per piece inside, 's0-s1' ('-' when none went in)."""
    durations = [piece["duration_s"] for piece in row.get("pieces", {}).values() if piece["result"] == "inside"]
    return f"{min(durations):.1f}-{max(durations):.1f}" if durations else "-"


def verdict_text(row: dict) -> str:
    verdict = row.get("verdict", {})
    return ", ".join({True: "yes", False: "no", None: "-"}[verdict.get(key)] for key in ("stable", "safe"))


def agreement(graph_rows: list[dict], runner_rows: list[dict]) -> str:
    """A markdown table: each graph trial beside the runner's trial of the same law, delay and seed (graph / runner):
    pieces inside, retries, task time, time per piece inside, peak force, time above F_max, stable and safe."""
    runner = {(row["law"], row["delay_s"], row["seed"]): row for row in runner_rows}
    lines = ["| law | seed | pieces inside | retries | task time [s] | s per piece inside | peak force [N] | "
             f"s above {FORCE_OF_NOTE_N:g} N | stable, safe |",
             "|---|---|---|---|---|---|---|---|---|"]
    for row in sorted(graph_rows, key=lambda row: (row["law"], row["delay_s"], row["seed"])):
        twin = runner.get((row["law"], row["delay_s"], row["seed"]))
        if twin is None:
            continue

        def pair(value) -> str:
            return f"{value(row)} / {value(twin)}"  # noqa: B023

        lines.append(f"| {row['law']}@{row['delay_s']:g} | {row['seed']} | "
                     f"{pair(lambda r: len(r['pieces_inside']))} | {pair(lambda r: r.get('retries', 0))} | "
                     f"{pair(lambda r: r.get('task_time_s') or '-')} | {pair(piece_times)} | "
                     f"{pair(lambda r: r['peak_force_n'])} | {pair(lambda r: r['time_above_f_max_s'])} | "
                     f"{pair(verdict_text)} |")
    return "\n".join(lines) + "\n"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``graph`` subcommand's options (fic_teleop_experiments.e2.command_line)."""
    parser.add_argument("--out", type=Path, default=None, help="the jsonl of finished trials (read, then appended)")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4], help="default 1 2 3 4 (the paper's 4)")
    parser.add_argument("--delay", type=float, default=0.2)
    parser.add_argument("--controller", default="fic", choices=("fic", "linear", "linear_bounded", "linear_tdpa"))
    parser.add_argument("--paper-law", action="store_true", help="the replica's Eq. 7 as the paper writes it")
    parser.add_argument("--duration", type=float, default=TRIAL_DURATION_S)
    parser.add_argument("--runs-dir", type=Path, default=Path("runs") / "e2_graph", help="the run folders")
    parser.add_argument("--wall-limit", type=float, default=7200.0)
    parser.add_argument("--summary", type=Path, default=None, help="instead of running: print ('-') or write the "
                                                                   "k/n of the jsonl")
    parser.add_argument("--holds", action="store_true", help="instead of running: for each trial of the jsonl, the "
                                                             "robot's stale-command holds with the clocks around "
                                                             "them (stale_holds) and the run's wall pace")
    parser.add_argument("--table", type=Path, nargs="+", default=None, metavar="JSONL",
                        help="instead of running: the sweep's markdown table of these graph jsonl files together "
                             "(one row a law and delay), or with --agreement the trials they hold")
    parser.add_argument("--agreement", type=Path, default=None, metavar="RUNNER_JSONL",
                        help="with --table: each graph trial beside the runner's trial of the same law, delay and "
                             "seed in this jsonl (the sweep's), as a markdown table")


def run_graph(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """The ``graph`` subcommand: run the seeds not in the jsonl yet, or report on what the jsonl files hold."""
    if args.agreement is not None and args.table is None:
        parser.error("--agreement needs --table (the graph's jsonl files)")
    if args.table is not None:
        from .sweep import summary as sweep_table

        rows = [row for path in args.table for row in read_rows(path)]
        print(agreement(rows, read_rows(args.agreement)) if args.agreement else sweep_table(rows), end="")
        return 0
    if args.out is None:
        parser.error("--out is needed (the trials' jsonl), except with --table")
    if args.holds:
        for row in read_rows(args.out):
            out = Path(row["run_dir"])
            print(f"{row['law']}@{row['delay_s']:g} seed {row['seed']}: wall per simulated ms {pace(out)}")
            for hold in stale_holds(out):
                print(f"  hold at {hold['t_s']:.3f} s: the bound before it took {hold['wall_s_for_bound']} s of wall "
                      f"time, {hold['commands_in_bound']} replica commands published in it, the newest computed on "
                      f"a state {hold.get('newest_state_age_ms')} ms old")
        return 0
    if args.summary is not None:
        text = summary(read_rows(args.out))
        print(text, end="") if str(args.summary) == "-" else args.summary.write_text(text)
        return 0
    args.runs_dir.mkdir(parents=True, exist_ok=True)
    law = args.controller + ("_paper_law" if args.paper_law else "")
    done = {(row["law"], row["delay_s"], row["seed"]) for row in read_rows(args.out)}
    close_cut_line(args.out)
    for seed in args.seeds:
        if (law, args.delay, seed) in done:
            continue
        row = run_trial(seed, args.delay, args.controller, args.paper_law, args.duration, args.runs_dir,
                        args.wall_limit)
        append_row(args.out, row)
        print(f"[e2-graph] {law}@{args.delay:g} seed {seed}: exit {row['launcher_exit_code']}, "
              f"{row['simulated_s']} s simulated in {row['wall_s']} s, {len(row['pieces_inside'])}/{len(PIECE_NAMES)} "
              f"inside, peak {row['peak_force_n']} N, stable {row['verdict']['stable']}, safe {row['verdict']['safe']}",
              flush=True)
    return 0

