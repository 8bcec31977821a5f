"""E2 (shape sorting) trials on the in-process runner: more seeds than the lockstep graph can run in a session.

With ``--operator shape_sorting`` (the default) each trial is driven by the closed-loop shape-sorting operator
(sim_bridge.device.shape_sorting_operator: it sees the delayed video, aligns piece over hole by move-and-wait and
feels the insertion) holding the handle with the force-reactive hand (device.reactive_hand); ``--operator scripted``
replays the lockstep graph's E2 script (config/operator_scripts/shape_sorting.yaml). Each seed varies the operator
as the claim runs do (fic_teleop_experiments.seed_jitter): the perception delay (or the script's clock) by up
to +-0.1 s, the hand's impedance by up to +-20 %, the reactive hand's latencies and gains from their ranges, with
5 ms of channel jitter. A piece counts when it ends inside the box (fic_teleop_experiments.shape_sorting.inside_box);
the outcome of each trial also gives the operator's phases, its retries and the time it took per piece.

    source scripts/env.sh
    python -m fic_teleop_experiments.e2 trial --trials 4 --json results/e2_operator_fic.json
    python -m fic_teleop_experiments.e2 trial --controller linear --first-seed 3 --trials 1 --json linear_3.json
    python -m fic_teleop_experiments.e2 trial --merge linear_1.json linear_3.json --json OUT.json --plot OUT.png
"""
from __future__ import annotations

import argparse
import json
import sys
from datetime import datetime
from pathlib import Path

import numpy as np
from tqdm import tqdm

from fic_teleop_experiments.cell_statistics import wilson_interval
from fic_teleop_experiments.in_process import RunConfig, run
from fic_teleop_experiments.seed_jitter import CHANNEL_JITTER_S, HAND_IMPEDANCE_JITTER, OPERATOR_TIMING_JITTER_S
from fic_teleop_experiments.shape_sorting import PIECE_NAMES, inside_box
from fic_teleop_runtime.workspace import config_folder
from fic_teleop_tools.verdict.run_verdict import VerdictCriterion, VerdictInput, judge
from sim_bridge.device.shape_sorting_operator import TRIAL_DURATION_S
from sim_bridge.device.virtual_operator import load_script

from .outcome import FORCE_OF_NOTE_N, operator_outcome


def trial(seed: int, duration: float, jitter: bool, operator: str, controller: str, delay: float,
          paper_law: bool | None = None) -> dict:
    """One seed's trial. ``paper_law``: the replica's Eq. 7 as the paper writes it (no inertial feedforward, no
    friction compensation); None: as this script always ran the FIC (written), the baselines as configured.
    ``duration`` is the task's; a quiet tail (VerdictCriterion.tail_needed, as a claim run's: the operator stops, the
    hand holds the handle, the link runs on) follows it, for the run verdict's free-response test. The force figures
    are the task's; the pieces are counted where they are at the end."""
    written = controller == "fic" if paper_law is None else paper_law
    tail = VerdictCriterion().tail_needed(delay)
    config = RunConfig(scene="shape_sorting", trajectory="fixed", duration=duration + tail, quiet_from=duration,
                       delay=delay, seed=seed,
                       controller=controller, operator=operator,
                       hand="reactive" if operator == "shape_sorting" else "passive",
                       replica_overrides={"paper_law": True} if written else {},
                       jitter=CHANNEL_JITTER_S if jitter else 0.0,
                       operator_timing_jitter=OPERATOR_TIMING_JITTER_S if jitter else 0.0,
                       hand_impedance_jitter=HAND_IMPEDANCE_JITTER if jitter else 0.0)
    result = run(config)
    inside = [name for name in PIECE_NAMES if inside_box(result.objects[name][0])]
    force = np.linalg.norm(result.force, axis=1) * (result.time < duration)   # the task's (the tail is the verdict's)
    dt = float(np.median(np.diff(result.time))) if len(result.time) > 1 else 0.0
    row = {"seed": seed, "pieces_inside": inside, "peak_force_n": round(float(force.max()), 1),
           "time_above_f_max_s": round(float((force > FORCE_OF_NOTE_N).sum() * dt), 2),
           "limit_violations": result.limit_violations, "operator_time_shift_s": round(result.operator_time_shift, 3),
           "hand_scale": round(result.hand_scale, 3), "wall_s": round(result.wall_s, 1),
           "simulated_s": round(result.simulated_s, 1), "joint_speed_max_rad_s": round(result.joint_speed_max, 2)}
    verdict = judge(VerdictInput.from_run_result(result, one_way_delay=delay))
    row["verdict"] = {"stable": verdict.stable, "safe": verdict.safe, "stable_reasons": verdict.stable_reasons,
                      "safe_reasons": verdict.safe_reasons}
    if operator == "shape_sorting":
        row["pieces"] = operator_outcome(result.operator_moves, force, result.time)
        finished = [piece["end_s"] for piece in row["pieces"].values() if piece["end_s"] is not None]
        row["task_time_s"] = round(max(finished), 2) if len(finished) == len(PIECE_NAMES) else None
        row["retries"] = sum(piece["retries"] for piece in row["pieces"].values())
        # |x_d - x_R|: beyond x_b (5 cm) the FIC's own force is bounded at F_max, so a force above F_max with the
        # error beyond x_b is the arm's (its momentum, the model terms), not the operator's command.
        row["trace"] = {"time": np.round(result.time[::25], 3).tolist(),
                        "force_n": np.round(force[::25], 2).tolist(),
                        "error_m": np.round(result.tracking_error[::25], 4).tolist(),
                        "phases": [(label, round(start, 2)) for label, start, _ in result.operator_moves]}
    return row


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``trial`` subcommand's options (fic_teleop_experiments.e2.command_line)."""
    parser.add_argument("--trials", type=int, default=4, help="seeds 1..N (default 4, the paper's count)")
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--operator", choices=("shape_sorting", "scripted"), default="shape_sorting")
    parser.add_argument("--controller", default="fic", help="fic (the paper's Eq. 7 as written, as the graph's E2), "
                                                            "linear, linear_bounded, linear_tdpa")
    parser.add_argument("--delay", type=float, default=0.2, help="one way [s] (default 0.2, the paper's)")
    parser.add_argument("--duration", type=float, default=None,
                        help=f"simulated s (default: the operator's {TRIAL_DURATION_S:g} s; the script's "
                             "length + 1 s)")
    parser.add_argument("--no-jitter", action="store_true", help="every trial as the lockstep graph's (seeds then "
                                                                  "differ only in the bonds' draws)")
    parser.add_argument("--json", type=Path, default=None, help="write the trials here")
    parser.add_argument("--merge", type=Path, nargs="+", default=None,
                        help="instead of running: combine these JSON files (one run each, e.g. one seed a process) "
                             "into --json")
    parser.add_argument("--plot", type=Path, default=None,
                        help="with --merge or a run: the replica's |F| against time for each trial, F_max and the "
                             "operator's phases (PNG)")


def run_trials(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """The ``trial`` subcommand: run seeds first-seed.. (or merge earlier runs), summarise, plot."""
    if args.merge:
        runs = [json.loads(path.read_text()) for path in args.merge]
        trials = sorted((row for run in runs for row in run["trials"]), key=lambda row: row["seed"])
        summarise(trials, {key: runs[0][key] for key in ("operator", "controller", "delay_s", "duration_s",
                                                         "jitter")}, args.json)
        return plot(trials, args.plot, runs[0]["controller"]) if args.plot else 0
    if args.trials < 1:
        parser.error("--trials must be at least 1")
    script = load_script(config_folder() / "operator_scripts" / "shape_sorting.yaml")
    # The operator's trial length, as on the graph (paper_experiments.py, e2/graph.py); the script's own length.
    duration = args.duration or (round(script.duration + 1.0, 1) if args.operator == "scripted" else TRIAL_DURATION_S)
    trials = []
    seeds = range(args.first_seed, args.first_seed + args.trials)
    for seed in tqdm(seeds, unit="trial", file=sys.stdout, dynamic_ncols=True):
        trials.append(trial(seed, duration, not args.no_jitter, args.operator, args.controller, args.delay))
        row = trials[-1]
        tqdm.write(f"[e2] seed {seed}: {len(row['pieces_inside'])} / {len(PIECE_NAMES)} inside "
                   f"({', '.join(row['pieces_inside']) or 'none'}), peak {row['peak_force_n']} N, "
                   f"{row['time_above_f_max_s']} s above {FORCE_OF_NOTE_N:g} N, {row['limit_violations']} limit "
                   f"violations, {row['wall_s']} s wall")
    summarise(trials, {"operator": args.operator, "controller": args.controller, "delay_s": args.delay,
                       "duration_s": duration, "jitter": not args.no_jitter}, args.json)
    return plot(trials, args.plot, args.controller) if args.plot and args.operator == "shape_sorting" else 0


#: The phases drawn on the force plot, one colour each (the rest of the log is left out of the figure).
PLOT_PHASES = {"reach": "tab:gray", "grasp": "tab:green", "carry": "tab:blue", "descend": "tab:orange",
               "search": "tab:purple", "insert": "tab:brown", "lock": "tab:pink", "pull": "tab:red",
               "done": "black", "gave_up": "black"}


def plot(trials: list[dict], path: Path, controller: str) -> int:
    """One panel per trial: |F_R| against time, F_max, and a line where each phase of PLOT_PHASES starts."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(len(trials), 1, figsize=(12, 2.4 * len(trials)), sharex=True, squeeze=False)
    for axis, row in zip(axes[:, 0], trials):
        trace = row["trace"]
        axis.plot(trace["time"], trace["force_n"], lw=0.7, color="tab:blue")
        axis.axhline(FORCE_OF_NOTE_N, color="tab:red", ls="--", lw=0.8, label="F_max")
        for label, start in trace["phases"]:
            phase = label.split(":", 1)[1]
            if phase in PLOT_PHASES:
                axis.axvline(start, color=PLOT_PHASES[phase], lw=0.6, alpha=0.7)
                axis.text(start, axis.get_ylim()[1] * 0.92, phase, rotation=90, fontsize=5, va="top",
                          color=PLOT_PHASES[phase])
        axis.set_ylabel("|F_R| [N]")
        axis.set_title(f"{controller}, seed {row['seed']}: {len(row['pieces_inside'])} / {len(PIECE_NAMES)} "
                       f"inside, {row.get('retries', 0)} retries", fontsize=8)
    axes[-1, 0].set_xlabel("time [s]")
    figure.tight_layout()
    figure.savefig(path, dpi=90)
    print(f"[e2] {path}")
    return 0


def summarise(trials: list[dict], setup: dict, path: Path | None) -> int:
    """Print the counts with their 95 % Wilson intervals and write the trials with them to ``path``."""
    complete = sum(len(row["pieces_inside"]) == len(PIECE_NAMES) for row in trials)
    pieces = sum(len(row["pieces_inside"]) for row in trials)
    complete_interval = wilson_interval(complete, len(trials))
    pieces_interval = wilson_interval(pieces, len(PIECE_NAMES) * len(trials))
    print(f"[e2] trials with every piece inside: {complete} of {len(trials)} (95 % Wilson {complete_interval[0]:.2f}-"
          f"{complete_interval[1]:.2f}); pieces inside: {pieces} of {len(PIECE_NAMES) * len(trials)} "
          f"({pieces_interval[0]:.2f}-{pieces_interval[1]:.2f}); limit violations: "
          f"{sum(row['limit_violations'] for row in trials)}")
    if path:
        path.write_text(json.dumps({"generated": datetime.now().isoformat(timespec="seconds"), **setup,
                                    "trials": trials, "complete": complete, "pieces_inside": pieces,
                                    "complete_wilson_95": [round(v, 3) for v in complete_interval],
                                    "pieces_wilson_95": [round(v, 3) for v in pieces_interval]}, indent=2) + "\n")
        print(f"[e2] {path}")
    return 0

