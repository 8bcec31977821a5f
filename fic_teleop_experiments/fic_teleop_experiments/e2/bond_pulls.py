"""E2 (shape sorting): the force at the bond in each lock and pull, beside the law's force and the F/T sensor's.

Why a piece stays on the plate is a question about three forces that the trial rows do not keep: the bond's own
force (the weld's constraint force on the piece, robot/adhesive_bond.py, which breaks the bond above its drawn
threshold), the law's Cartesian force FIC(x~_R) (paper Eq. 7's controller term: per axis at most F_max = 10 N, so at
most sqrt(2) F_max = 14.1 N with two axes past x_b, as in a lock (x) held while pulling (z)) and the F/T sensor's
|F_R| at the replica, which the trials report. This reads them per lock-and-pull window (from the operator's
``lock`` to the phase after its ``pulled``: the return from the pull is in it):

- in process, by running one trial (e2.trial, the sweep's or the graph's twin's draws) with the
  simulation and the replica station recorded at every 1 ms physics step; the trial itself is the same;
- on the graph, from a run folder: the bag's /replica/fic_state (the law's force and error per axis, 100 Hz),
  /ft_sensor/wrench and the robot's /diagnostics (the bond's force, 1 Hz samples: not peaks), and the robot log's
  bond events (formed with its threshold, broke at a force).

    source scripts/env.sh
    python -m fic_teleop_experiments.e2 bond-pulls --seed 3 --law fic --json results/e2_bond_pulls_fic_3.json
    python -m fic_teleop_experiments.e2 bond-pulls --seed 3 --law fic --no-jitter ...     # the graph's twin
    python -m fic_teleop_experiments.e2 bond-pulls --graph runs/e2_graph_fic/fic_0.2_seed3 --jsonl \
        results/e2_graph_fic.jsonl
    python -m fic_teleop_experiments.e2 bond-pulls --plot results/e2_bond_pulls_seed3.png --results A.json B.json
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import re
from pathlib import Path
from typing import Iterator

import numpy as np

from fic_teleop_experiments import in_process

from .sweep import LAWS

STEP_S = 0.001
#: x_b of config/replica.yaml (paper Sec. III): beyond it an axis of Eq. 1 is saturated toward F_max.
SATURATION_ERROR_M = 0.05
#: The phases of one lock-and-pull (shape_sorting_operator._lock_and_pull); the window runs to the next other phase.
PULL_PHASES = ("lock", "pull", "pulled")


class _Recorder:
    """Per physics step: the bond's force, its threshold, the law's force |FIC| (translation), its inertial
    feedforward |Lambda a_d| and the number of translation axes with |x_d - x_R| beyond x_b."""

    def __init__(self) -> None:
        self.station = None
        self.rows: list[tuple[float, float, float, float, float, int]] = []
        self._breaks = 0

    def record(self, simulation) -> None:
        bond = simulation.bond_state
        broke, self._breaks = bond.breaks > self._breaks, bond.breaks
        command = None if self.station is None else self.station.loop.last_command
        law = feedforward = 0.0
        saturated = 0
        if command is not None:
            wrench = command.wrench
            law = math.sqrt(float(wrench[0] ** 2 + wrench[1] ** 2 + wrench[2] ** 2))
            if command.feedforward_wrench is not None:
                feedforward = float(np.linalg.norm(command.feedforward_wrench[:3]))
            saturated = sum(abs(e) > SATURATION_ERROR_M for e in command.tracking_error_values[:3])
        if broke:   # the step the bond broke on: the force that broke it (the bond is gone after the step)
            force, threshold = bond.last_break_force, bond.break_threshold
        else:
            force, threshold = (bond.bond_force, bond.break_threshold) if bond.bonded_piece else (0.0, 0.0)
        self.rows.append((simulation.steps * STEP_S, force, threshold, law, feedforward, saturated))


@contextlib.contextmanager
def recording() -> Iterator[_Recorder]:
    """in_process.run with its simulation and replica station swapped for recording subclasses (same behaviour)."""
    recorder = _Recorder()
    simulation_class, station_class = in_process.PandaSimulation, in_process.ReplicaStation

    class RecordedSimulation(simulation_class):
        def step(self, torque) -> None:
            super().step(torque)
            recorder.record(self)

    class RecordedStation(station_class):
        def __init__(self, *args, **kwargs) -> None:
            super().__init__(*args, **kwargs)
            recorder.station = self

    in_process.PandaSimulation, in_process.ReplicaStation = RecordedSimulation, RecordedStation
    try:
        yield recorder
    finally:
        in_process.PandaSimulation, in_process.ReplicaStation = simulation_class, station_class


def windows(phases: list[tuple[str, float]], end: float) -> list[tuple[str, float, float]]:
    """(piece, start, end) of each lock-and-pull: from a ``lock`` to the first later phase not in PULL_PHASES."""
    found = []
    for index, (label, start) in enumerate(phases):
        piece, phase = label.split(":", 1)
        if phase != "lock":
            continue
        stop = next((later for name, later in phases[index + 1:] if name.split(":", 1)[1] not in PULL_PHASES), end)
        found.append((piece, start, stop))
    return found


def felt_pulls(row: dict) -> list[float]:
    """The force the operator felt at the end of each pull (its ``pulled`` phase), every piece of a trial row."""
    return [value for piece in row["pieces"].values() for phase, _, value in piece["phases"] if phase == "pulled"]


def in_process_pulls(seed: int, law: str, delay: float, jitter: bool, duration: float) -> dict:
    """One trial recorded (module docstring): its row (without the trace) and one entry per lock-and-pull."""
    from .trial import trial

    controller, paper_law = LAWS[law]
    with recording() as recorder:
        row = trial(seed, duration, jitter, "shape_sorting", controller, delay, paper_law=paper_law)
    series = np.array(recorder.rows)
    time, force = np.asarray(row["trace"]["time"]), np.asarray(row["trace"]["force_n"])
    entries = []
    for piece, start, stop in windows(row["trace"]["phases"], float(series[-1, 0])):
        inside = (series[:, 0] >= start) & (series[:, 0] < stop)
        part = series[inside]
        bonded = part[part[:, 2] > 0.0]   # a bond that broke in the window: its last row with a threshold broke it
        peak = int(np.argmax(part[:, 1])) if part.size else 0
        trace_window = (time >= start) & (time < stop)
        entries.append({
            "piece": piece, "start_s": round(start, 2), "end_s": round(stop, 2),
            "threshold_n": round(float(bonded[0, 2]), 1) if bonded.size else None,
            "bond_peak_n": round(float(part[:, 1].max()), 1) if part.size else None,
            "broke": bool(bonded.size and bonded[-1, 1] > bonded[-1, 2]),
            "law_peak_n": round(float(part[:, 3].max()), 1) if part.size else None,
            "law_at_bond_peak_n": round(float(part[peak, 3]), 1) if part.size else None,
            "feedforward_peak_n": round(float(part[:, 4].max()), 1) if part.size else None,
            "feedforward_at_bond_peak_n": round(float(part[peak, 4]), 1) if part.size else None,
            "axes_beyond_x_b_at_bond_peak": int(part[peak, 5]) if part.size else None,
            "ft_peak_n_4hz": round(float(force[trace_window].max()), 1) if trace_window.any() else None})
    felt = felt_pulls(row)
    # The series at 100 Hz for the plot: each 10 ms's largest bond and law force (a one-step peak is kept).
    usable = len(series) // 10 * 10
    blocks = series[:usable].reshape(-1, 10, series.shape[1])
    plotted = {"time": np.round(blocks[:, 0, 0], 2).tolist(), "bond_n": np.round(blocks[:, :, 1].max(1), 2).tolist(),
               "threshold_n": np.round(blocks[:, :, 2].max(1), 1).tolist(),
               "law_n": np.round(blocks[:, :, 3].max(1), 2).tolist(),
               "feedforward_n": np.round(blocks[:, :, 4].max(1), 2).tolist(),
               "ft_time": row["trace"]["time"], "ft_n": row["trace"]["force_n"]}
    summary = {key: row[key] for key in ("seed", "pieces_inside", "peak_force_n", "time_above_f_max_s", "retries",
                                         "operator_time_shift_s", "hand_scale", "wall_s")}
    return {"law": law, "delay_s": delay, "jitter": jitter, **summary, "felt_pulls_n": felt, "pulls": entries,
            "series": plotted}


BOND_EVENT = re.compile(r"bond with (\w+) (formed \(breaks above ([\d.]+) N\)|broke at ([\d.]+) N)")


def graph_pulls(run_dir: Path, row: dict) -> dict:
    """One graph trial (its folder and its e2.graph row): one entry per lock-and-pull (module docstring)."""
    from mcap_ros2.decoder import DecoderFactory

    from fic_teleop_runtime.stamps import seconds
    from fic_teleop_tools.recording.bag_reader import ReadResult, read_messages

    bag = run_dir / "bag"
    factory, decoders = DecoderFactory(), {}
    law_rows, bond_rows = [], []
    for schema, channel, message in read_messages(bag, ReadResult()):
        if channel.topic not in ("/replica/fic_state", "/diagnostics"):
            continue
        decoder = decoders.get(channel.id)
        if decoder is None:
            decoder = decoders[channel.id] = factory.decoder_for(channel.message_encoding, schema)
        msg = decoder(message.data)
        stamp = seconds(msg.header.stamp)
        if channel.topic == "/replica/fic_state":
            law_rows.append((stamp, math.sqrt(sum(f * f for f in msg.force[:3])),
                             sum(abs(e) > SATURATION_ERROR_M for e in msg.error[:3])))
        else:
            for status in msg.status:
                values = {kv.key: kv.value for kv in status.values}
                if "bond_force_n" in values:
                    bond_rows.append((stamp, float(values["bond_force_n"]), values.get("bonded_piece", "")))
    law = np.array(sorted(law_rows)) if law_rows else np.zeros((0, 3))
    bond_time = np.array([r[0] for r in bond_rows])
    bond_force = np.array([r[1] for r in bond_rows])
    events = []
    log = run_dir / "logs" / "robot.log"
    for line in log.read_text().splitlines() if log.exists() else []:
        found = BOND_EVENT.search(line)
        if found:
            events.append((found.group(1), "formed" if found.group(3) else "broke",
                           float(found.group(3) or found.group(4))))
    time, force = np.asarray(row["trace"]["time"]), np.asarray(row["trace"]["force_n"])
    entries = []
    for piece, start, stop in windows([tuple(p) for p in row["trace"]["phases"]], float(time[-1])):
        in_law = (law[:, 0] >= start) & (law[:, 0] < stop) if law.size else np.zeros(0, bool)
        in_bond = (bond_time >= start) & (bond_time < stop)
        in_trace = (time >= start) & (time < stop)
        part = law[in_law]
        peak = int(np.argmax(part[:, 1])) if part.size else 0
        entries.append({
            "piece": piece, "start_s": round(start, 2), "end_s": round(stop, 2),
            "bond_samples_max_n_1hz": round(float(bond_force[in_bond].max()), 1) if in_bond.any() else None,
            "law_peak_n_100hz": round(float(part[:, 1].max()), 1) if part.size else None,
            "axes_beyond_x_b_at_law_peak": int(part[peak, 2]) if part.size else None,
            "ft_peak_n_10hz": round(float(force[in_trace].max()), 1) if in_trace.any() else None})
    felt = felt_pulls(row)
    return {"law": row["law"], "delay_s": row["delay_s"], "seed": row["seed"], "pieces_inside": row["pieces_inside"],
            "bond_events": events, "felt_pulls_n": felt, "pulls": entries}


def table(result: dict) -> str:
    """A markdown table of one trial's lock-and-pulls."""
    keys = [key for key in result["pulls"][0]] if result["pulls"] else []
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(str(entry[key]) for key in keys) + " |" for entry in result["pulls"]]
    return "\n".join(lines) + "\n"


def pulls_row(result: dict, piece: str = "cuboid") -> str:
    """One markdown row of an in-process result: a piece's pulls, the bond's peak in each, the pull that broke it,
    the law's force and the feedforward at the bond's peaks (ranges over the pulls)."""
    pulls = [entry for entry in result["pulls"] if entry["piece"] == piece]
    broke = next((index + 1 for index, entry in enumerate(pulls) if entry["broke"]), None)

    def span(key: str) -> str:
        values = [entry[key] for entry in pulls if entry.get(key) is not None]
        return f"{min(values):.1f}-{max(values):.1f}" if values else "-"

    who = f"{result['law']}, " + ("the sweep's draws" if result["jitter"] else "the graph's twin")
    peaks = ", ".join(f"{entry['bond_peak_n']:.1f}" for entry in pulls)
    outcome = f"at pull {broke}" if broke else "no"
    return (f"| {who} | {len(pulls)} | {peaks} | {outcome} | {span('law_at_bond_peak_n')} | "
            f"{span('feedforward_at_bond_peak_n')} |")


def plot(results: list[dict], titles: list[str], path: Path) -> None:
    """One panel per in-process result: the bond's force and its threshold, the law's |FIC| with sqrt(2) F_max (two
    axes saturated), the inertial feedforward, the F/T |F_R| (4 Hz) and the lock-and-pull windows shaded."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(len(results), 1, figsize=(12, 2.6 * len(results)), sharex=True, squeeze=False)
    for axis, result, title in zip(axes[:, 0], results, titles):
        series = result["series"]
        axis.plot(series["ft_time"], series["ft_n"], lw=0.5, color="0.7", label="|F_R| (F/T, 4 Hz)")
        axis.plot(series["time"], series["law_n"], lw=0.6, color="tab:green", label="|FIC| (the law)")
        axis.plot(series["time"], series["feedforward_n"], lw=0.5, color="tab:orange", label="|Lambda a_d|")
        axis.plot(series["time"], series["bond_n"], lw=0.8, color="tab:blue", label="bond force")
        threshold = np.asarray(series["threshold_n"], dtype=float)
        axis.plot(series["time"], np.where(threshold > 0, threshold, np.nan), color="tab:red", ls="--", lw=0.8,
                  label="bond's break threshold")
        axis.axhline(math.sqrt(2) * 10.0, color="tab:green", ls=":", lw=0.8, label="sqrt(2) F_max")
        for entry in result["pulls"]:
            axis.axvspan(entry["start_s"], entry["end_s"], color="tab:red" if entry["broke"] else "0.5", alpha=0.12)
        axis.set_ylim(0, 25)
        axis.set_ylabel("[N]")
        axis.set_title(f"{title}: {len(result['pieces_inside'])} / 3 inside", fontsize=8)
    axes[0, 0].legend(fontsize=6, ncol=6, loc="upper left")
    axes[-1, 0].set_xlabel("time [s]")
    figure.tight_layout()
    figure.savefig(path, dpi=90)
    print(f"[e2-bond] {path}")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``bond-pulls`` subcommand's options (fic_teleop_experiments.e2.command_line)."""
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--law", choices=tuple(LAWS), default="fic")
    parser.add_argument("--delay", type=float, default=0.2)
    parser.add_argument("--duration", type=float, default=None, help="simulated s (default: the operator's trial)")
    parser.add_argument("--no-jitter", action="store_true",
                        help="the graph's twin: no per-seed operator draws, no channel jitter")
    parser.add_argument("--graph", type=Path, default=None, help="instead of running: a graph trial's run folder")
    parser.add_argument("--jsonl", type=Path, default=None, help="with --graph: the graph trials' jsonl holding its "
                                                                 "row")
    parser.add_argument("--json", type=Path, default=None, help="write the result here")
    parser.add_argument("--plot", type=Path, default=None, metavar="PNG",
                        help="instead of running: plot the in-process results given by --results")
    parser.add_argument("--results", type=Path, nargs="+", default=None, metavar="JSON",
                        help="with --plot or --table: results of in-process runs (--json), one panel or row each")
    parser.add_argument("--table", action="store_true",
                        help="instead of running: one markdown row a result of --results (the cuboid's pulls)")


def run_bond_pulls(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """The ``bond-pulls`` subcommand: one trial's pulls (in process, or a graph run's), or a plot or table of
    earlier results."""
    if args.table:
        if not args.results:
            parser.error("--table needs --results")
        for path in args.results:
            print(pulls_row(json.loads(path.read_text())))
        return 0
    if args.plot is not None:
        if not args.results:
            parser.error("--plot needs --results")
        results = [json.loads(path.read_text()) for path in args.results]
        plot(results, [f"{r['law']} at {r['delay_s']:g} s, seed {r['seed']}"
                       + ("" if r["jitter"] else ", the graph's twin") for r in results], args.plot)
        return 0
    if args.graph is not None:
        if args.jsonl is None:
            parser.error("--graph needs --jsonl (the trial's row: its phases and trace)")
        rows = [json.loads(line) for line in args.jsonl.read_text().splitlines() if line.strip()]
        row = next((r for r in rows if Path(r["run_dir"]).resolve() == args.graph.resolve()), None)
        if row is None:
            parser.error(f"{args.jsonl} has no row whose run_dir is {args.graph}")
        result = graph_pulls(args.graph, row)
    else:
        from sim_bridge.device.shape_sorting_operator import TRIAL_DURATION_S

        result = in_process_pulls(args.seed, args.law, args.delay, not args.no_jitter,
                                  args.duration or TRIAL_DURATION_S)
    print(json.dumps({key: value for key, value in result.items() if key not in ("pulls", "series")}))
    print(table(result), end="")
    if args.json:
        args.json.write_text(json.dumps(result, indent=1) + "\n")
    return 0

