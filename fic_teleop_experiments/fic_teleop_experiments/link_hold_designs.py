"""The two designs of the replica's low-rate command path (fic_core.link_hold) on the same claim runs.

Each run is a claim run (the closed-loop operator, the reactive hand, 0.2 s each way) with the replica's
``interpolate_link_samples`` set to each design; with ``--feedback off`` the master's K_H is 0, so the offset that
reaches the replica is an exogenous input and the replica's gain from it to the arm can be read off the run
(replica_response.response, Welch H1). Per run: the peak gain on 0.3-1 Hz with its frequency and coherence,
the tracking error and the run verdict's answer.

    python -m fic_teleop_experiments.link_hold_designs --seeds 5 6 7 --rates 10 0 --workers 2
    # -> results/link_hold_designs.json (docs/CONTROL_LAWS.md "Low-rate links")
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from concurrent.futures import as_completed
from pathlib import Path
from tempfile import TemporaryDirectory

import numpy as np

from fic_teleop_experiments.claims import SETTLE_S, ClaimRun, figures, judge_series, save_series, thinned
from fic_teleop_experiments.engine import make_executor
from fic_teleop_experiments.in_process import run
from fic_teleop_experiments.replica_response import response
from fic_teleop_runtime.workspace import working_folder

REPO = working_folder()   # runs/ and results/ (FIC_TELEOP_ROOT, else the current folder)
DESIGNS = {"interpolate": True, "extrapolate": False}
#: The band the gain is reported on [Hz]: the arm's resonance on the FIC's spring lies in it (0.6-0.9 Hz).
GAIN_BAND_HZ = (0.3, 1.0)
DELAY_S = 0.2


def one_run(design: str, rate_hz: float, seed: int, feedback: bool, duration: float) -> dict:
    claim = ClaimRun(DELAY_S, rate_hz, "fic", "reactive", seed, duration, force_feedback=feedback)
    config = claim.config()
    config = dataclasses.replace(config, replica_overrides={**config.replica_overrides,
                                                            "interpolate_link_samples": DESIGNS[design]})
    result = run(config)
    keep = result.time >= SETTLE_S
    frequency, transfer, coherence = response(result.time[keep], (result.desired - result.planner)[keep],
                                              (result.tcp - result.planner)[keep])
    band = (frequency >= GAIN_BAND_HZ[0]) & (frequency <= GAIN_BAND_HZ[1])
    peak = int(np.argmax(np.abs(transfer[band])))
    with TemporaryDirectory() as directory:
        path = Path(directory) / f"{claim.key}.npz"
        save_series(path, thinned(result))
        verdict = judge_series(path, DELAY_S)
    row_figures = figures(claim, result)
    return dict(design=design, rate_hz=rate_hz, seed=seed, feedback=feedback, duration_s=duration,
                peak_gain=float(np.abs(transfer[band])[peak]), peak_frequency_hz=float(frequency[band][peak]),
                coherence_at_peak=float(coherence[band][peak]),
                error_rms_mm=1e3 * row_figures["error_rms_m"], error_max_mm=1e3 * row_figures["error_max_m"],
                stable=verdict["stable"], stable_reasons=verdict["stable_reasons"])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[5, 6, 7])
    parser.add_argument("--rates", type=float, nargs="+", default=[10.0, 0.0], help="link rates [Hz], 0: full rate")
    parser.add_argument("--feedback", choices=("off", "on", "both"), default="off")
    parser.add_argument("--designs", nargs="+", choices=tuple(DESIGNS), default=list(DESIGNS))
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=REPO / "results" / "link_hold_designs.json")
    args = parser.parse_args(argv)
    feedbacks = {"off": [False], "on": [True], "both": [False, True]}[args.feedback]
    jobs = [(d, r, s, f,
             args.duration) for f in feedbacks for r in args.rates for s in args.seeds for d in args.designs]
    rows = []
    with make_executor(None, args.workers) as executor:
        futures = [executor.submit(one_run, *job) for job in jobs]
        for future in as_completed(futures):
            row = future.result()
            rows.append(row)
            print(json.dumps({k: (round(v, 3) if isinstance(v, float) else v) for k, v in row.items()}), flush=True)
    rows.sort(key=lambda r: (r["feedback"], r["rate_hz"], r["seed"], r["design"]))
    summary = {}
    for key in sorted({(r["feedback"], r["rate_hz"], r["design"]) for r in rows}):
        group = [r for r in rows if (r["feedback"], r["rate_hz"], r["design"]) == key]
        summary[f"feedback_{'on' if key[0] else 'off'}__rate_{key[1]:g}__{key[2]}"] = dict(
            runs=len(group), peak_gain_max=max(r["peak_gain"] for r in group),
            peak_gain_median=float(np.median([r["peak_gain"] for r in group])),
            error_rms_mm_median=float(np.median([r["error_rms_mm"] for r in group])),
            stable=sum(r["stable"] for r in group))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"delay_s": DELAY_S, "band_hz": GAIN_BAND_HZ, "summary": summary, "runs": rows},
                                   indent=1) + "\n")
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
