#!/usr/bin/env python3
"""E2 (shape sorting) trials on the in-process runner: more seeds than the lockstep graph can run in a session.

Each trial is the E2 run of the lockstep graph (the scripted operator, 200 ms each way, the replica's Eq. 7 as the
paper writes it, docs/EXPERIMENTS.md "E2") with the seed's variations of the evidence sweep: the script's clock
shifted by up to +-0.1 s, the hand's impedance scaled by up to +-20 %, 5 ms of channel jitter
(sim_bridge.experiments.evidence_run). The closed-loop operator drives E1 only (it has no policy for finding
pieces and holes in a video), so E2 keeps the script. A piece counts when it ends inside the box
(sim_bridge.experiments.shape_sorting.inside_box).

    source scripts/env.sh && python scripts/e2_in_process.py --trials 8 --json results/e2_in_process.json
"""
from __future__ import annotations

import argparse
import json
import sys
from datetime import datetime
from pathlib import Path

import numpy as np
from tqdm import tqdm

REPO = Path(__file__).resolve().parent.parent

from sim_bridge.device.virtual_operator import load_script  # noqa: E402
from sim_bridge.experiments.evidence_run import (CHANNEL_JITTER_S, HAND_IMPEDANCE_JITTER,  # noqa: E402
                                                 OPERATOR_TIMING_JITTER_S)
from sim_bridge.experiments.in_process import RunConfig, run  # noqa: E402
from sim_bridge.experiments.shape_sorting import PIECE_NAMES, inside_box  # noqa: E402

FORCE_OF_NOTE_N = 10.0   # the replica's F_max: time spent above it is reported, as in the graph's E2 table


def trial(seed: int, duration: float, jitter: bool) -> dict:
    config = RunConfig(scene="shape_sorting", trajectory="fixed", duration=duration, delay=0.2, seed=seed,
                       replica_overrides={"paper_law": True},
                       jitter=CHANNEL_JITTER_S if jitter else 0.0,
                       operator_timing_jitter=OPERATOR_TIMING_JITTER_S if jitter else 0.0,
                       hand_impedance_jitter=HAND_IMPEDANCE_JITTER if jitter else 0.0)
    result = run(config)
    inside = [name for name in PIECE_NAMES if inside_box(result.objects[name][0])]
    force = np.linalg.norm(result.force, axis=1)
    dt = float(np.median(np.diff(result.time))) if len(result.time) > 1 else 0.0
    return {"seed": seed, "pieces_inside": inside, "peak_force_n": round(float(force.max()), 1),
            "time_above_f_max_s": round(float((force > FORCE_OF_NOTE_N).sum() * dt), 2),
            "limit_violations": result.limit_violations, "operator_time_shift_s": round(result.operator_time_shift, 3),
            "hand_scale": round(result.hand_scale, 3), "wall_s": round(result.wall_s, 1),
            "simulated_s": round(result.simulated_s, 1)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--trials", type=int, default=8, help="seeds 1..N (default 8)")
    parser.add_argument("--no-jitter", action="store_true", help="every trial as the lockstep graph's (seeds then "
                                                                  "differ only in the bonds' draws)")
    parser.add_argument("--json", type=Path, default=None, help="write the trials here")
    args = parser.parse_args(argv)
    if args.trials < 1:
        parser.error("--trials must be at least 1")
    script = load_script(REPO / "config" / "operator_scripts" / "shape_sorting.yaml")
    duration = round(script.duration + 1.0, 1)   # the graph's E2 duration (scripts/experiments.py)
    trials = []
    for seed in tqdm(range(1, args.trials + 1), unit="trial", file=sys.stdout, dynamic_ncols=True):
        trials.append(trial(seed, duration, not args.no_jitter))
        row = trials[-1]
        tqdm.write(f"[e2] seed {seed}: {len(row['pieces_inside'])} / {len(PIECE_NAMES)} inside "
                   f"({', '.join(row['pieces_inside']) or 'none'}), peak {row['peak_force_n']} N, "
                   f"{row['time_above_f_max_s']} s above {FORCE_OF_NOTE_N:g} N, {row['limit_violations']} limit "
                   f"violations, {row['wall_s']} s wall")
    complete = sum(len(row["pieces_inside"]) == len(PIECE_NAMES) for row in trials)
    pieces = sum(len(row["pieces_inside"]) for row in trials)
    print(f"[e2] trials with every piece inside: {complete} of {len(trials)}; pieces inside: {pieces} of "
          f"{len(PIECE_NAMES) * len(trials)}; limit violations: {sum(row['limit_violations'] for row in trials)}")
    if args.json:
        args.json.write_text(json.dumps({"generated": datetime.now().isoformat(timespec="seconds"),
                                         "duration_s": duration, "jitter": not args.no_jitter,
                                         "trials": trials, "complete": complete, "pieces_inside": pieces},
                                        indent=2) + "\n")
        print(f"[e2] {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
