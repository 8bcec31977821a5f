"""Where a claim run's quiet tail begins: on the fixed obstacle, or off it.

The quiet tail judges the loop's free response (docs/EXPERIMENTS.md, "The run verdict"). A tail that begins with the
arm on E1's fixed obstacle judges a different loop: the arm held on a stiff contact, whose impacts return to the
operator's hand one round trip later through the force feedback. The A/B of fic_teleop_experiments.tail_contact
showed that loop cycling at 1 s of delay for the FIC (through the replica's offset feedforward) and the linear laws,
while the same runs stopped 2 s earlier or later settle.
So the claim statistics are also given for the runs whose tail begins off the obstacle.

The criterion is fixed before it is applied and decided before the free response starts, so it cannot select on the
outcome: the arm touches the fixed obstacle during the tail's driven start, the first ``one-way delay +
SETTLE_AFTER_LAST_COMMAND_S`` seconds of the tail, while the commands sent before the freeze still arrive (they take
the one-way delay) and the arm settles after the last of them. Contact that begins later belongs to the free
response and does not count.

    python -m fic_teleop_experiments.tail_start results/claims_tail_v3.json --series results/claims_tail_v3_runs \\
        --out results/claims_tail_v3_tail_start.json
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

#: [s] after the last command sent before the freeze arrives: the arm's settling (the E1 circle's TCP speed is
#: 0.13 m/s; the FIC's attractor stops it within about 0.2 s).
SETTLE_AFTER_LAST_COMMAND_S = 1.0


def tail_begins_on_obstacle(time: np.ndarray, obstacle_contact: np.ndarray, quiet_from: float,
                            one_way_delay: float) -> bool:
    """Whether the arm touches the fixed obstacle in the tail's driven start (module docstring)."""
    window = (time >= quiet_from) & (time < quiet_from + one_way_delay + SETTLE_AFTER_LAST_COMMAND_S)
    return bool(np.any(np.asarray(obstacle_contact)[window]))


def classify_runs(judged: Path, series_folder: Path, earlier: dict[str, dict] | None = None) -> dict[str, dict]:
    """For each judged run of ``judged`` (claims_sweep's summary): whether its tail begins on the obstacle, or
    None when its series is not in ``series_folder`` (a run judged before its series was lost is kept by its
    verdict alone), unless ``earlier`` (an earlier classification of the same sweep, by run key) has it: a series
    lost with a machine keeps the classification read from it while it was there."""
    from fic_teleop_experiments.claims_report import read_runs

    out: dict[str, dict] = {}
    for row in read_runs(judged):
        series = series_folder / str(row.get("series"))
        on_obstacle = None
        if row.get("series") and series.is_file():
            with np.load(series) as data:
                if "obstacle_contact" in data.files and "quiet_from" in data.files:
                    on_obstacle = tail_begins_on_obstacle(data["time"], data["obstacle_contact"],
                                                          float(data["quiet_from"]), float(row["delay"]))
        if on_obstacle is None:
            on_obstacle = (earlier or {}).get(row["key"], {}).get("tail_begins_on_obstacle")
        out[row["key"]] = {"tail_begins_on_obstacle": on_obstacle}
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Whether each claim run's quiet tail begins on the fixed obstacle")
    parser.add_argument("judged", type=Path, help="the judged sweep (results/claims_tail_v3.json)")
    parser.add_argument("--series", type=Path, required=True, help="the sweep's series folder")
    parser.add_argument("--out", type=Path, required=True,
                        help="the JSON written: run key -> classification (an existing one is kept for the runs whose "
                             "series is gone)")
    args = parser.parse_args(argv)
    if not args.judged.is_file() or not args.series.is_dir():
        parser.error(f"need a judged sweep file and a series folder, got {args.judged} and {args.series}")
    earlier = json.loads(args.out.read_text())["runs"] if args.out.is_file() else None
    runs = classify_runs(args.judged, args.series, earlier)
    args.out.write_text(json.dumps({"criterion": __doc__.split("\n\n")[2].replace("\n", " "),
                                    "settle_after_last_command_s": SETTLE_AFTER_LAST_COMMAND_S,
                                    "runs": runs}, indent=1) + "\n")
    known = [r["tail_begins_on_obstacle"] for r in runs.values() if r["tail_begins_on_obstacle"] is not None]
    print(f"{len(runs)} runs: {sum(known)} begin on the obstacle, {len(known) - sum(known)} off it, "
          f"{len(runs) - len(known)} without a series")
    return 0


if __name__ == "__main__":
    sys.exit(main())
