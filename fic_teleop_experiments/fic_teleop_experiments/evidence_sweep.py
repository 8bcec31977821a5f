"""Stability maps from the in-process runner, judged by energy and motion (docs/EXPERIMENTS.md).

Cells: the one-way delay (E1 scene); three bandwidth sweeps, each named for what it lowers: (a) the command
bandwidth (the channel's rate cap, the law at full rate; the claim cells, claims_sweep.py, cap both
directions with the operator closing the loop), and, stricter than the FIC papers claimed, (b) the FIC feedback
rate (the Cartesian law J^T FIC + posture at control_rate while the arm's gravity and C qd are compensated at the
1 kHz physics rate, as on a Franka) and (c) the whole torque loop's rate (gravity included in the held torque); each run with the FIC, the FIC as the
paper writes it (paper_law), the linear baseline, the linear baseline bounded at the FIC's F_max and that one made
passive at the channel's ports (linear_tdpa), over seeds (channel jitter, operator timing, hand impedance). Per run the verdict of
fic_teleop_experiments.energy_verdict; per cell k/n stable with a 95 % Wilson interval, median/p95 of the error
and the peak force (fic_teleop_experiments.cell_statistics). Writes <out>.json and <out>_map.png.

    python -m fic_teleop_experiments.evidence_sweep --quick            # 5 cells x 5 controllers x 2 seeds, 20 s
    python -m fic_teleop_experiments.evidence_sweep --seeds 5 --duration 30 --workers 2
    python -m fic_teleop_experiments.evidence_sweep --operator closed_loop   # the operator watching the delayed video
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from fic_teleop_experiments.cell_statistics import cell_statistics
from fic_teleop_experiments.evidence_run import (CHANNEL_JITTER_S, CONTROLLERS, HAND_IMPEDANCE_JITTER,
                                                 OPERATOR_TIMING_JITTER_S, judge)
from fic_teleop_experiments.in_process import OPERATORS

REPO = Path(__file__).resolve().parents[2]
def cells(quick: bool) -> list[dict]:
    """(id, label, what it lowers, runner options)."""
    delays = (0.2, 1.0) if quick else (0.0, 0.2, 0.5, 1.0, 2.0)
    command_rates = (10.0,) if quick else (1000.0, 50.0, 10.0, 5.0)
    torque_rates = (10.0,) if quick else (1000.0, 50.0, 10.0, 5.0)
    feedback_rates = (10.0,) if quick else (1000.0, 50.0, 10.0, 5.0)
    out = [dict(id=f"delay_{d:g}", family="delay (one way)", value=d, options=dict(delay=d)) for d in delays]
    out += [dict(id=f"command_rate_{r:g}", family="command bandwidth: channel rate cap, law at 1 kHz", value=r,
                 options=dict(delay=0.2, rate_cap=r)) for r in command_rates]
    out += [dict(id=f"feedback_rate_{r:g}", family="stricter than claimed: FIC feedback rate, J^T FIC + posture, C qd + G at 1 kHz", value=r,
                 options=dict(delay=0.2, control_rate=r, dynamics_at_physics_rate=True)) for r in feedback_rates]
    out += [dict(id=f"torque_loop_{r:g}", family="stricter than claimed: whole torque loop rate (gravity held too)", value=r,
                 options=dict(delay=0.2, control_rate=r)) for r in torque_rates]
    return out


def stability_map(summary: list[dict], path: Path) -> None:
    controllers = list(dict.fromkeys(row["controller"] for row in summary))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    ids = list(dict.fromkeys(row["cell"] for row in summary))
    figure, axes = plt.subplots(figsize=(1.6 * len(ids) + 1.5, 0.9 * len(controllers) + 1.2))
    share = np.full((len(controllers), len(ids)), np.nan)
    for row in summary:
        i, j = controllers.index(row["controller"]), ids.index(row["cell"])
        s = row["statistics"]
        if s["assessed"]:
            share[i, j] = s["stable"] / s["assessed"]
        axes.text(j, i, f"{s['stable']}/{s['assessed']}" + ("" if s["assessed"] == s["runs"] else f" ({s['runs']})"),
                  ha="center", va="center", fontsize=11)
    axes.imshow(share, cmap="RdYlGn", vmin=0.0, vmax=1.0, aspect="auto")
    axes.set_xticks(range(len(ids)), ids, rotation=30, ha="right")
    axes.set_yticks(range(len(controllers)), controllers)
    axes.set_title("stable k/n (energy-and-motion verdict)")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def ports_summary(runs: list[dict]) -> dict:
    """The channel's passivity figures of a cell's runs: median generated energy (of the assessed runs: a run too
    short to judge has no port figures), the observers' smallest W."""
    generated = [r["ports"]["channel_generated_total_j"] for r in runs if "channel_generated_total_j" in r["ports"]]
    return dict(channel_generated_median_j=float(np.median(generated)) if generated else None,
                observer_min_j=float(min(min(r["channel_observer_min_j"].values()) for r in runs)),
                offset_drift_max_m=float(max(r["offset_drift_max_m"] for r in runs)))


def table(document: dict) -> str:
    """The cells of a sweep's JSON as a markdown table (docs/EXPERIMENTS.md pastes it)."""
    lines = ["| cell | lowers | controller | stable k/n | 95 % Wilson | error RMS median [mm] | error max p95 [mm] "
             "| peak force median / p95 [N] | channel generated median [J] | observer W min [J] |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for row in document["cells"]:
        s = row["statistics"]
        interval = s["stable_interval_95"]
        lines.append(f"| {row['cell']} | {row['family']} | {row['controller']} | {s['stable']}/{s['assessed']}"
                     + ("" if s["assessed"] == s["runs"] else f" ({s['runs']} run)")
                     + f" | {'-' if interval is None else f'{interval[0]:.2f}-{interval[1]:.2f}'}"
                     f" | {s['error_median_m'] * 1e3:.1f} | {s['error_p95_m'] * 1e3:.1f}"
                     f" | {s['peak_force_median_n']:.1f} / {s['peak_force_p95_n']:.1f}"
                     + (f" | {row['ports']['channel_generated_median_j']:.3f} | {row['ports']['observer_min_j']:.3f} |"
                        if row.get("ports", {}).get("channel_generated_median_j") is not None else " | - | - |"))
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--seeds", type=int, default=None)
    parser.add_argument("--duration", type=float, default=None)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--only", nargs="*", default=None, help="cell ids to run")
    parser.add_argument("--controllers", nargs="*", default=list(CONTROLLERS), choices=CONTROLLERS)
    parser.add_argument("--operator", default="scripted", choices=OPERATORS,
                        help="scripted: the E1 script timed for each cell's delay; closed_loop: timed from the "
                             "delayed video (docs/EXPERIMENTS.md)")
    parser.add_argument("--script-delay", type=float, default=None,
                        help="time the scripted E1 operator for this one-way delay [s] in every cell (default: each "
                             "cell's own delay); results/evidence_baselines used 0.2")
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--series", type=Path, default=None,
                        help="directory for every run's time series (evidence_run.save_series)")
    parser.add_argument("--reuse-series", action="store_true",
                        help="judge the runs already in --series from their files instead of simulating them")
    parser.add_argument("--table-from", type=Path, default=None, help="print the markdown table of a sweep's JSON")
    args = parser.parse_args(argv)
    if args.table_from is not None:
        print(table(json.loads(args.table_from.read_text())), end="")
        return 0
    seeds = args.seeds or (2 if args.quick else 5)
    duration = args.duration or (20.0 if args.quick else 30.0)
    out = args.out or REPO / "results" / ("evidence_quick" if args.quick else "evidence")
    timing = {} if args.script_delay is None else {"script_delay": args.script_delay}
    chosen = [{**c, "options": {**c["options"], "operator": args.operator, **timing}}
              for c in cells(args.quick) if args.only is None or c["id"] in args.only]
    if args.reuse_series and args.series is None:
        parser.error("--reuse-series needs --series")
    jobs = [(c, controller, seed, duration, args.series, args.reuse_series) for c in chosen for controller in args.controllers for seed in range(1, seeds + 1)]
    start = time.perf_counter()
    runs = []
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for done, row in enumerate(pool.map(judge, jobs), 1):
            runs.append(row)
            print(f"[{done}/{len(jobs)}] {row['cell']} {row['controller']} seed {row['seed']}: "
                  f"{'stable' if row['stable'] else ('not assessed' if row['stable'] is None else 'UNSTABLE')} "
                  f"err {row['error_rms_m'] * 1e3:.1f} mm rms, F {row['peak_force_n']:.1f} N, "
                  f"{row['simulated_s'] / row['wall_s']:.2f} sim s/wall s", flush=True)
    wall = time.perf_counter() - start
    summary = []
    for c in chosen:
        for controller in args.controllers:
            mine = [r for r in runs if r["cell"] == c["id"] and r["controller"] == controller]
            stats = cell_statistics([r["stable"] for r in mine], [r["error_rms_m"] for r in mine],
                                    [r["error_max_m"] for r in mine], [r["peak_force_n"] for r in mine])
            summary.append(dict(cell=c["id"], family=c["family"], value=c["value"], controller=controller,
                                statistics=stats.as_dict(), ports=ports_summary(mine)))
    simulated = sum(r["simulated_s"] for r in runs)
    document = dict(seeds=seeds, duration_s=duration, operator=args.operator, channel_jitter_s=CHANNEL_JITTER_S,
                    operator_timing_jitter_s=OPERATOR_TIMING_JITTER_S, hand_impedance_jitter=HAND_IMPEDANCE_JITTER,
                    workers=args.workers, wall_s=wall, simulated_s=simulated,
                    # Runs judged from kept series (--reuse-series) were simulated earlier: wall_s is then mostly
                    # judging, and the runs' own wall_s sum is the simulation's.
                    runs_from_series=sum(1 for r in runs if r["from_series"]),
                    runs_wall_s_sum=float(sum(r["wall_s"] for r in runs)),
                    sim_s_per_wall_s_per_run=float(np.median([r["simulated_s"] / r["wall_s"] for r in runs])),
                    cells=summary, runs=runs)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".json").write_text(json.dumps(document, indent=1))
    stability_map(summary, out.parent / (out.name + "_map.png"))
    (out.parent / (out.name + "_table.md")).write_text(table(document))
    for row in summary:
        s = row["statistics"]
        interval = s["stable_interval_95"]
        print(f"{row['cell']:>20} {row['controller']:>14}: {s['stable']}/{s['assessed']} stable"
              + (f" [{interval[0]:.2f}, {interval[1]:.2f}]" if interval else "")
              + f", err median {s['error_median_m'] * 1e3:.1f} mm, p95 max {s['error_p95_m'] * 1e3:.1f} mm, "
                f"F median {s['peak_force_median_n']:.1f} N p95 {s['peak_force_p95_n']:.1f} N")
    print(f"{len(runs)} runs, {simulated:.0f} simulated s in {wall:.0f} wall s ({simulated / wall:.2f} sim s per wall s "
          f"with {args.workers} workers)" + (f"; {document['runs_from_series']} judged from kept series"
                                             if document["runs_from_series"] else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
