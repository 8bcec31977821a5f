"""E2 (shape sorting) sweep on the in-process runner: every law at the paper's 200 ms and at 0, 0.5 and 1 s, with
the closed-loop shape-sorting operator and the force-reactive hand (one trial: e2.trial). Resumable: every finished
trial is one line of the jsonl (--out); a rerun skips the trials already there, so the sweep can be stopped and
restarted at any time. Trials are submitted seed-major (seed 1 of every cell, then seed 2, ...), so whatever has
finished covers every cell. They run on the sweeps' engine (fic_teleop_experiments.engine, docs/CLUSTER.md): one
worker process by default, which runs them one after another in that order; --workers N, --engine dask or
--cluster ADDRESS run several at once, each line appended as its trial finishes.

Laws: fic (the replica's default, config/replica.yaml: Eq. 7 with the inertial feedforward and the friction
compensation), fic_paper_law (Eq. 7 as the paper writes it), linear, linear_bounded, linear_tdpa (linear_bounded
behind the channel's time-domain passivity controllers).

    source scripts/env.sh
    nice -n 5 python -m fic_teleop_experiments.e2 sweep --out results/e2_sweep.jsonl --seeds 10   # run (or resume)
    nice -n 5 python -m fic_teleop_experiments.e2 sweep --out results/e2_sweep.jsonl --cells fic@0.2 linear@0.2
    # the paper's cell first, every law to 10 seeds, then the default cells (the 200 ms ones are skipped as done)
    python -m fic_teleop_experiments.e2 sweep --out results/e2_sweep.jsonl --seeds 10 --cells fic@0.2 \
        fic_paper_law@0.2 linear@0.2 linear_bounded@0.2 linear_tdpa@0.2
    python -m fic_teleop_experiments.e2 sweep --out results/e2_sweep.jsonl --summary results/e2_sweep.md  # k/n
"""
from __future__ import annotations

import argparse
from collections import defaultdict
from concurrent.futures import Executor, as_completed
from pathlib import Path

from fic_teleop_experiments.cell_statistics import wilson_interval
from fic_teleop_experiments.engine import EngineError, add_engine_arguments, engine_from_arguments
from fic_teleop_experiments.shape_sorting import PIECE_NAMES
from sim_bridge.device.shape_sorting_operator import TRIAL_DURATION_S

from .jsonl import append_row, close_cut_line, read_rows
from .outcome import FORCE_OF_NOTE_N, phase_forces
from .trial import plot, trial

#: law -> (the runner's controller, the paper's Eq. 7 as written)
LAWS = {"fic": ("fic", False), "fic_paper_law": ("fic", True), "linear": ("linear", False),
        "linear_bounded": ("linear_bounded", False), "linear_tdpa": ("linear_tdpa", False)}
#: The delays each way [s]: the paper's 200 ms first, then the sweep's 0, 0.5 and 1 s.
DELAYS_S = (0.2, 0.0, 0.5, 1.0)
#: The cells in the order each seed runs them: every law at the paper's delay, then every law at each other delay.
DEFAULT_CELLS = tuple(f"{law}@{delay:g}" for delay in DELAYS_S for law in LAWS)


def parse_cell(text: str) -> tuple[str, float]:
    law, separator, delay = text.partition("@")
    if not separator or law not in LAWS:
        raise argparse.ArgumentTypeError(f"a cell is LAW@DELAY with LAW one of {tuple(LAWS)}, got {text!r}")
    try:
        value = float(delay)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a cell's delay must be a number of seconds, got {delay!r}") from None
    if not 0.0 <= value <= 5.0:
        raise argparse.ArgumentTypeError(f"a cell's delay must be 0-5 s, got {value}")
    return law, value


def verdicts(trials: list[dict], name: str) -> str:
    """k/n of the trials the run verdict judged ``name`` (fic_teleop_tools.verdict.run_verdict); not assessed left
    out."""
    judged = [row["verdict"][name] for row in trials if row.get("verdict", {}).get(name) is not None]
    return f"{sum(judged)}/{len(judged)}"


def summary(rows: list[dict]) -> str:
    """A markdown table: per cell, trials complete and pieces inside with their 95 % Wilson intervals, time per
    piece inside, peak force, time above F_max, retries, limit violations."""
    cells: dict[tuple[str, float], list[dict]] = defaultdict(list)
    for row in rows:
        cells[(row["law"], row["delay_s"])].append(row)
    lines = ["| law | delay [s] | trials complete (95 % Wilson) | pieces inside (95 % Wilson) | s per piece inside | "
             f"peak force [N], median (max) | s above {FORCE_OF_NOTE_N:g} N, median | retries | limit violations | "
             "stable / safe (run verdict) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    order = {parse_cell(cell): index for index, cell in enumerate(DEFAULT_CELLS)}
    for key in sorted(cells, key=lambda key: (order.get(key, len(order)), key)):
        trials = cells[key]
        n = len(trials)
        complete = sum(len(row["pieces_inside"]) == len(PIECE_NAMES) for row in trials)
        pieces = sum(len(row["pieces_inside"]) for row in trials)
        low, high = wilson_interval(complete, n)
        piece_low, piece_high = wilson_interval(pieces, n * len(PIECE_NAMES))
        durations = [piece["duration_s"] for row in trials for piece in row.get("pieces", {}).values()
                     if piece["result"] == "inside"]
        peaks = sorted(row["peak_force_n"] for row in trials)
        above = sorted(row["time_above_f_max_s"] for row in trials)
        per_piece = f"{sum(durations) / len(durations):.1f}" if durations else "-"
        lines.append(f"| {key[0]} | {key[1]:g} | {complete}/{n} ({low:.2f}-{high:.2f}) | "
                     f"{pieces}/{n * len(PIECE_NAMES)} ({piece_low:.2f}-{piece_high:.2f}) | {per_piece} | "
                     f"{peaks[n // 2]:.1f} ({peaks[-1]:.1f}) | "
                     f"{above[n // 2]:.1f} | {sum(row.get('retries', 0) for row in trials)} | "
                     f"{sum(row['limit_violations'] for row in trials)} | {verdicts(trials, 'stable')} / "
                     f"{verdicts(trials, 'safe')} |")
    return "\n".join(lines) + "\n"


def why(rows: list[dict]) -> str:
    """The failed pieces' contact phases (phase_forces) and the operator's own log of them."""
    lines = []
    for row in rows:
        failed = [name for name, piece in row.get("pieces", {}).items() if piece["result"] != "inside"]
        if not failed:
            continue
        lines.append(f"{row['law']}@{row['delay_s']:g} seed {row['seed']}: {len(row['pieces_inside'])}/"
                     f"{len(PIECE_NAMES)} inside; not inside: {', '.join(failed)}")
        for shape in failed:
            piece = row["pieces"][shape]
            felt = [value for phase, _, value in piece["phases"] if phase == "pulled"]
            lines.append(f"  {shape}: {piece['grasps']} grasp(s), {piece['insertions']} insertion(s); the strongest "
                         f"pull the operator felt in each pull [N]: {felt}")
            for label, start, end, force, error in phase_forces(row):
                if label.startswith(f"{shape}:"):
                    lines.append(f"    {label:28s} {start:7.2f}-{end:7.2f} s  peak |F_R| {force:5.1f} N"
                                 + (f"  max |x_d - x_R| {error * 1000:5.1f} mm" if error is not None else ""))
    return "\n".join(lines) + ("\n" if lines else "")


def cell_trial(law: str, delay: float, seed: int, duration: float) -> dict:
    """One trial of a cell (the row the jsonl keeps): the law's controller and Eq. 7 reading, the sweep's draws."""
    controller, paper_law = LAWS[law]
    row = trial(seed, duration, True, "shape_sorting", controller, delay, paper_law=paper_law)
    return {"law": law, "delay_s": delay, **row}


def run_cells(out: Path, cells: list[tuple[str, float]], seeds: int, duration: float, executor: Executor) -> int:
    """Every trial of ``cells`` x seeds 1..``seeds`` not yet in ``out``, submitted seed-major to ``executor``; each
    row appended to ``out`` as its trial finishes. Returns how many ran."""
    done = {(row["law"], row["delay_s"], row["seed"]) for row in read_rows(out)}
    todo = [(law, delay, seed) for seed in range(1, seeds + 1) for law, delay in cells
            if (law, delay, seed) not in done]
    print(f"[e2-sweep] {len(done)} trials done, {len(todo)} to run", flush=True)
    close_cut_line(out)
    futures = [executor.submit(cell_trial, law, delay, seed, duration) for law, delay, seed in todo]
    for future in as_completed(futures):
        row = future.result()
        append_row(out, row)
        print(f"[e2-sweep] {row['law']}@{row['delay_s']:g} seed {row['seed']}: {len(row['pieces_inside'])}/"
              f"{len(PIECE_NAMES)} inside, peak {row['peak_force_n']} N, {row['time_above_f_max_s']} s above "
              f"{FORCE_OF_NOTE_N:g} N, {row['wall_s']} s wall", flush=True)
    return len(todo)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``sweep`` subcommand's options (fic_teleop_experiments.e2.command_line)."""
    parser.add_argument("--out", type=Path, required=True, help="the jsonl of finished trials (read, then appended)")
    parser.add_argument("--cells", type=parse_cell, nargs="+", default=None, metavar="LAW@DELAY",
                        help="the cells to run, seed-major; default: every law at every delay, "
                             f"{' '.join(DEFAULT_CELLS)}")
    parser.add_argument("--seeds", type=int, default=10, help="seeds 1..N a cell (default 10)")
    parser.add_argument("--duration", type=float, default=TRIAL_DURATION_S, help="simulated s a trial")
    parser.add_argument("--summary", type=Path, default=None,
                        help="instead of running: write the table of what the jsonl holds here ('-': print it)")
    parser.add_argument("--plot", type=Path, default=None, metavar="PREFIX",
                        help="instead of running: one PNG a cell, PREFIX_<law>_<delay>.png: |F_R| against time for "
                             "each trial, F_max and the operator's phases")
    parser.add_argument("--why", action="store_true",
                        help="instead of running: for every trial that left a piece outside, each failed piece's "
                             "contact phases with the replica's peak force and largest |x_d - x_R| in each, and what "
                             "the operator logged (the felt force, the seen error)")
    parser.add_argument("--workers", type=int, default=None,
                        help="worker processes on this machine (default 1: one trial after another, seed-major)")
    add_engine_arguments(parser)


def run_sweep(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """The ``sweep`` subcommand: run (or resume) the cells, or report on what the jsonl holds."""
    if args.why:
        print(why(read_rows(args.out)), end="")
        return 0
    if args.plot is not None:
        cells: dict[tuple[str, float], list[dict]] = defaultdict(list)
        for row in read_rows(args.out):
            cells[(row["law"], row["delay_s"])].append(row)
        for (law, delay), trials in sorted(cells.items()):
            plot(sorted(trials, key=lambda row: row["seed"]), Path(f"{args.plot}_{law}_{delay:g}.png"),
                 f"{law} at {delay:g} s")
        return 0
    if args.summary is not None:
        table = summary(read_rows(args.out))
        if str(args.summary) == "-":
            print(table, end="")
        else:
            args.summary.write_text(table)
            print(f"[e2-sweep] {args.summary}")
        return 0
    if args.seeds < 1:
        parser.error("--seeds must be at least 1")
    cells = args.cells or [parse_cell(cell) for cell in DEFAULT_CELLS]
    if args.workers is None and args.cluster is None:
        args.workers = 1   # on this machine, one trial at a time unless told (a cluster brings its own workers)
    try:
        with engine_from_arguments(args) as engine:
            run_cells(args.out, cells, args.seeds, args.duration, engine.executor)
    except EngineError as error:
        parser.error(str(error))
    return 0
