"""The claim sweep's results document: every run with both verdicts and its seed, and per cell the statistics that
compare the laws (docs/EXPERIMENTS.md, "Claims"; the statistics are sim_bridge.experiments.cell_statistics's).

Input: the sweep's run file (results/claims_runs.jsonl), one JSON object a line, one line a run, carrying at least

    cell        the claim cell's id (its delay and rates are in the cell's own fields, kept as they are)
    controller  the law
    seed        the run's seed
    stable      True / False / None (None: too short to judge), or absent when the run failed
    safe        True / False
    error_rms_m, error_max_m, peak_force_n   the run's tracking error (RMS and maximum) and peak force

and, when the sweep varies them, ``operator`` and ``hand`` (a cell is then one (cell, operator, hand) triple). A run
that appears twice (a resumed sweep that ran it again) counts once, its last line. A line without a ``stable`` key
is a run that did not finish (the sweep writes why in ``failure``); it is counted, not judged.

Output (``claims_document``): {"runs": [...], "cells": [...], "comparisons": [...], "seeds_planned", ...}; each cell:
stable and safe k/n with Wilson 95 % intervals, the seeds judged, median and p95 of the RMS error, the maximum error
and the peak force; each comparison: the reference law (the FIC) against one baseline on one cell, for both
verdicts, p_FIC - p_baseline with Newcombe's 95 % interval, Boschloo's exact p and Fisher's.

    python -m sim_bridge.experiments.claims_report results/claims_runs.jsonl --out results/claims
"""
from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path

from sim_bridge.experiments.cell_statistics import Proportion, compare_laws, median_and_p95, proportion

REFERENCE_LAW = "fic"
VERDICTS = ("stable", "safe")
#: The fields that tell one cell's runs from another's besides the cell id (absent fields are left out).
CELL_KEYS = ("cell", "operator", "hand")
#: The per-run figures summarised as median and p95.
FIGURES = {"error_rms_m": "error_rms", "error_max_m": "error_max", "peak_force_n": "peak_force"}


def read_runs(path: Path) -> list[dict]:
    """The run file's lines, the last line of each (cell, operator, hand, controller, seed) kept; a line that is not
    JSON (a sweep stopped mid-write) is skipped."""
    runs: dict[tuple, dict] = {}
    with open(path) as lines:
        for line in lines:
            line = line.strip()
            if not line:
                continue
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue
            runs[run_key(row)] = row
    return list(runs.values())


def cell_key(row: dict) -> tuple:
    return tuple(row.get(name) for name in CELL_KEYS)


def run_key(row: dict) -> tuple:
    return (*cell_key(row), row.get("controller"), row.get("seed"))


def _cell_name(key: tuple) -> dict:
    return {name: value for name, value in zip(CELL_KEYS, key) if value is not None}


def _finished(rows: Iterable[dict]) -> list[dict]:
    return [row for row in rows if "stable" in row]


def law_statistics(rows: Sequence[dict]) -> dict:
    """One law on one cell: both verdicts' k/n with Wilson intervals, the seeds, median and p95 of the figures."""
    finished = _finished(rows)
    out = {"runs": len(rows), "finished": len(finished),
           "seeds": sorted(row.get("seed") for row in finished),
           **{verdict: proportion([row.get(verdict) for row in finished]).as_dict() for verdict in VERDICTS}}
    for field, name in FIGURES.items():
        median, p95 = median_and_p95([row.get(field) for row in finished])
        out[f"{name}_median"], out[f"{name}_p95"] = median, p95
    return out


def claims_document(runs: Sequence[dict], seeds_planned: int | None = None,
                    reference: str = REFERENCE_LAW) -> dict:
    """The results document (module docstring) of the runs so far."""
    by_cell: dict[tuple, dict[str, list[dict]]] = {}
    for row in runs:
        by_cell.setdefault(cell_key(row), {}).setdefault(row.get("controller"), []).append(row)
    cells, comparisons = [], []
    for key, laws in by_cell.items():
        sample = next(iter(laws.values()))[0]
        # What the cell is (its delay, rates, label), as the run rows carry it.
        described = {name: value for name, value in sample.items()
                     if name == "options" or name.startswith(("delay", "command_rate", "feedback_rate", "rate",
                                                               "family", "label"))}
        statistics = {law: law_statistics(rows) for law, rows in sorted(laws.items(), key=lambda item: str(item[0]))}
        cells.append({**_cell_name(key), **described, "laws": statistics})
        if reference not in statistics:
            continue
        for law, stats in statistics.items():
            if law == reference:
                continue
            comparison = {**_cell_name(key), "reference": reference, "baseline": law}
            for verdict in VERDICTS:
                ours, theirs = statistics[reference][verdict], stats[verdict]
                result = compare_laws(_as_proportion(ours), _as_proportion(theirs))
                comparison[verdict] = {"difference": result.difference,
                                       "difference_interval_95": result.difference_interval_95,
                                       "boschloo_p": result.boschloo_p, "fisher_p": result.fisher_p,
                                       "reference_k_n": [ours["k"], ours["n"]], "baseline_k_n": [theirs["k"], theirs["n"]]}
            comparisons.append(comparison)
    judged = [row for row in runs if row.get("stable") is not None]
    return {"seeds_planned": seeds_planned, "runs_total": len(runs), "runs_finished": len(_finished(runs)),
            "runs_judged_stable": len(judged), "reference_law": reference,
            "statistics": {"proportion_interval": "Wilson score, 95 %",
                           "difference_interval": "Newcombe hybrid score (method 10), 95 %",
                           "test": "Boschloo exact, two-sided (scipy: twice the smaller one-sided p); Fisher exact "
                                   "two-sided beside it", "figures": "median and 95th percentile (numpy, linear)"},
            "cells": cells, "comparisons": comparisons, "runs": list(runs)}


def _as_proportion(share: dict) -> Proportion:
    interval = share["interval_95"]
    return Proportion(share["k"], share["n"], None if interval is None else tuple(interval))


def write_claims(runs_path: Path, out: Path, seeds_planned: int | None = None) -> dict[str, Path]:
    """results/claims.json (<out>.json), its Markdown tables (<out>_tables.md) and figures (<out>_*.png) from the run
    file; returns the paths written (a figure that has nothing to show is not written)."""
    from sim_bridge.experiments.plots import plot_claim_differences, plot_claim_proportions
    from sim_bridge.experiments.tables import claims_markdown

    document = claims_document(read_runs(runs_path), seeds_planned)
    document["source"] = str(runs_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    written = {"json": out.with_suffix(".json"), "tables": out.parent / f"{out.name}_tables.md"}
    written["json"].write_text(json.dumps(document, indent=1) + "\n")
    written["tables"].write_text(claims_markdown(document))
    for name, plot in (("proportions", plot_claim_proportions), ("differences", plot_claim_differences)):
        path = plot(document, out.parent / f"{out.name}_{name}.png")
        if path is not None:
            written[name] = path
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="results/claims.json, its tables and figures from the run file")
    parser.add_argument("runs", type=Path, help="the sweep's run file (results/claims_runs.jsonl)")
    parser.add_argument("--out", type=Path, default=None, help="output stem (default: <runs' folder>/claims)")
    parser.add_argument("--seeds-planned", type=int, default=None, help="the seeds a cell is planned to have")
    args = parser.parse_args(argv)
    if not args.runs.is_file():
        parser.error(f"no run file at {args.runs}")
    written = write_claims(args.runs, args.out or args.runs.parent / "claims", args.seeds_planned)
    for name, path in written.items():
        print(f"{name}: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
