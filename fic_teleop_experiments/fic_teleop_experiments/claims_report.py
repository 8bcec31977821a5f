"""The claim sweep's statistics: per cell and law both verdicts' k/n with Wilson intervals, the FIC against each
baseline, error and force median and p95, as JSON, Markdown tables and figures (docs/EXPERIMENTS.md, "Claims"; the
statistics are fic_teleop_experiments.cell_statistics's).

Input: the judged sweep, results/claims.json (``scripts/experiments.sh claims --judge``: every run's row with its
seed, figures and both verdicts), or any run file of one JSON row a line. A row carries ``cell``, ``controller``,
``seed``, when the sweep varies them ``operator`` and ``hand`` (a cell is then one (cell, operator, hand) triple),
the verdicts either nested (``verdict: {stable, safe}``, the claim sweep's) or flat (``stable``, ``safe``), and
``error_rms_m``, ``error_max_m``, ``peak_force_n`` either under ``figures`` or flat. ``stable`` None is a run too
short to judge; a row without a verdict is a run not judged (yet): counted, never judged. A run that appears twice
(a resumed sweep) counts once, its last row.

Output (``claims_statistics``): {"cells": [...], "comparisons": [...], counts}; each cell per law: stable and safe
k/n with Wilson 95 % intervals, the seeds judged, median and p95 of the swing (the verdict's figure: x_R's swing
about its command during the task), the RMS error, the maximum error and the peak force; each comparison: the FIC
against one baseline on one cell, for both verdicts, p_FIC - p_baseline with Newcombe's 95 % interval, Boschloo's
exact p and Fisher's.

    python -m fic_teleop_experiments.claims_report results/claims.json      # -> results/claims_statistics.json,
                                                                             #    claims_tables.md, claims_*.png
    python -m fic_teleop_experiments.claims_report --block results/claims_statistics.json   # RESULTS.md's block
    python -m fic_teleop_experiments.claims_report results/claims.json --update-results docs/RESULTS.md   # all, and it
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from fic_teleop_experiments.cell_statistics import Proportion, compare_laws, median_and_p95, proportion
from fic_teleop_experiments.tables import claims_block, claims_markdown
from fic_teleop_experiments.unstable_tests import unstable_by_test

REFERENCE_LAW = "fic"
VERDICTS = ("stable", "safe")
#: The fields that tell one cell's runs from another's besides the cell id (absent fields are left out).
CELL_KEYS = ("cell", "operator", "hand")
#: The per-run figures summarised as median and p95.
FIGURES = {"error_rms_m": "error_rms", "error_max_m": "error_max", "peak_force_n": "peak_force"}


def read_runs(path: Path) -> list[dict]:
    """The runs of a judged sweep document (a JSON object with ``runs``) or of a run file (one JSON row a line; a
    line that is not JSON, a sweep stopped mid-write, is skipped); the last row of each run kept."""
    text = Path(path).read_text()
    rows: list[dict] = []
    try:
        document = json.loads(text)
        rows = list(document["runs"]) if isinstance(document, dict) else list(document)
    except json.JSONDecodeError:
        for line in text.splitlines():
            try:
                rows.append(json.loads(line))
            except json.JSONDecodeError:
                continue
    runs: dict[tuple, dict] = {}
    for row in rows:
        runs[run_key(row)] = row
    return list(runs.values())


def cell_key(row: dict) -> tuple:
    return tuple(row.get(name) for name in CELL_KEYS)


def run_key(row: dict) -> tuple:
    return (*cell_key(row), row.get("controller"), row.get("seed"))


def _cell_name(key: tuple) -> dict:
    return {name: value for name, value in zip(CELL_KEYS, key) if value is not None}


def verdict_of(row: dict, verdict: str):
    """The row's ``stable`` / ``safe`` verdict (nested under ``verdict`` or flat); KeyError when not judged."""
    return row["verdict"][verdict] if "verdict" in row else row[verdict]


def judged(row: dict) -> bool:
    return isinstance(row.get("verdict"), dict) or "stable" in row


def figure_of(row: dict, name: str):
    return row.get("figures", row).get(name)


def law_statistics(rows: Sequence[dict]) -> dict:
    """One law on one cell: both verdicts' k/n with Wilson intervals, the seeds, median and p95 of the figures."""
    finished = [row for row in rows if judged(row)]
    out = {"runs": len(rows), "judged": len(finished),
           "seeds": sorted(row.get("seed") for row in finished),
           **{verdict: proportion([verdict_of(row, verdict) for row in finished]).as_dict() for verdict in VERDICTS},
           "unstable_by_test": unstable_by_test(finished)}
    for field, name in FIGURES.items():
        median, p95 = median_and_p95([figure_of(row, field) for row in finished])
        out[f"{name}_median"], out[f"{name}_p95"] = median, p95
    # The verdict's resonant amplification (run_verdict: the peak gain of x_R to the operator's planned target, the
    # period of the peak), kept so that a forced resonance the verdict no longer calls an oscillation stays visible.
    verdict_figures = [row["verdict"].get("figures") or {} for row in finished if isinstance(row.get("verdict"), dict)]
    out["resonance_gain_median"], out["resonance_gain_p95"] = median_and_p95(
        [f.get("resonance_gain") for f in verdict_figures])
    out["resonance_period_median_s"] = median_and_p95([f.get("resonance_period_s") for f in verdict_figures])[0]
    # The swing (run_verdict: the oscillation scan's amplitude of x_R about its command during the task), beside the
    # stable share: a law that is stable but swings 20 mm about its command is worse for fine work than its share says.
    out["swing_median"], out["swing_p95"] = median_and_p95([f.get("swing_m") for f in verdict_figures])
    return out


def _cell_order(cell: dict) -> tuple:
    """Delay, then the link's rate from full (0) down, then the hand."""
    rate = cell.get("rate_hz")
    return (cell.get("delay", 0.0), -(rate or float("inf")) if rate is not None else 0.0, str(cell.get("hand")),
            str(cell.get("cell")))


def claims_statistics(runs: Sequence[dict], seeds_planned: int | None = None,
                      reference: str = REFERENCE_LAW) -> dict:
    """The statistics (module docstring) of the runs judged so far."""
    by_cell: dict[tuple, dict[str, list[dict]]] = {}
    for row in runs:
        by_cell.setdefault(cell_key(row), {}).setdefault(row.get("controller"), []).append(row)
    cells, comparisons = [], []
    for key, laws in by_cell.items():
        sample = next(iter(laws.values()))[0]
        # What the cell is (its delay, the link's rate, the run length), as the run rows carry it.
        described = {name: sample[name] for name in ("delay", "rate_hz", "duration") if name in sample}
        statistics = {law: law_statistics(rows) for law, rows in sorted(laws.items(), key=lambda item: str(item[0]))}
        cells.append({**_cell_name(key), **described, "laws": statistics})
    cells.sort(key=_cell_order)
    for cell in cells:
        statistics = cell["laws"]
        if reference not in statistics:
            continue
        for law, stats in statistics.items():
            if law == reference:
                continue
            comparison = {name: cell[name] for name in CELL_KEYS if name in cell}
            comparison.update(reference=reference, baseline=law)
            for verdict in VERDICTS:
                ours, theirs = statistics[reference][verdict], stats[verdict]
                result = compare_laws(_as_proportion(ours), _as_proportion(theirs))
                comparison[verdict] = {"difference": result.difference,
                                       "difference_interval_95": result.difference_interval_95,
                                       "boschloo_p": result.boschloo_p, "fisher_p": result.fisher_p,
                                       "reference_k_n": [ours["k"], ours["n"]],
                                       "baseline_k_n": [theirs["k"], theirs["n"]]}
            comparisons.append(comparison)
    return {"seeds_planned": seeds_planned, "runs_total": len(runs), "runs_judged": sum(1 for r in runs if judged(r)),
            "runs_judged_stable": sum(1 for r in runs if judged(r) and verdict_of(r, "stable") is not None),
            "reference_law": reference,
            "statistics": {"proportion_interval": "Wilson score, 95 %",
                           "difference_interval": "Newcombe hybrid score (method 10), 95 %",
                           "test": "Boschloo exact, two-sided (scipy: twice the smaller one-sided p); Fisher exact "
                                   "two-sided beside it", "figures": "median and 95th percentile (numpy, linear)"},
            "cells": cells, "comparisons": comparisons}


def _as_proportion(share: dict) -> Proportion:
    interval = share["interval_95"]
    return Proportion(share["k"], share["n"], None if interval is None else tuple(interval))


def runs_by_tail_start(runs: Sequence[dict], classification: Path, on_obstacle: bool) -> list[dict]:
    """The runs whose quiet tail begins on the fixed obstacle (``on_obstacle``) or off it, by the classification
    fic_teleop_experiments.tail_start wrote; a run it could not classify (no series) is left out of both."""
    kinds = json.loads(Path(classification).read_text())["runs"]
    return [row for row in runs
            if kinds.get(row.get("key"), {}).get("tail_begins_on_obstacle") is on_obstacle]


def write_claims_statistics(source: Path, out: Path, seeds_planned: int | None = None,
                            tail_start: tuple[Path, bool] | None = None) -> dict[str, Path]:
    """<out>.json (the statistics), <out stem>_tables.md and the figures <out stem>_proportions.png and
    _differences.png from a judged sweep or run file; returns the paths written (a figure with nothing to show is
    not written). The stem of results/claims_statistics.json is results/claims. ``tail_start`` (classification
    file, on the obstacle or not) keeps only the runs whose tail begins so (runs_by_tail_start)."""
    from fic_teleop_experiments.plots import plot_claim_differences, plot_claim_proportions

    runs = read_runs(source)
    if tail_start is not None:
        runs = runs_by_tail_start(runs, *tail_start)
    document = claims_statistics(runs, seeds_planned)
    document["source"] = Path(source).name
    if tail_start is not None:
        document["runs_kept"] = ("runs whose quiet tail begins on the fixed obstacle" if tail_start[1] else
                                 "runs whose quiet tail begins off the fixed obstacle") + \
            f" ({Path(tail_start[0]).name}; runs without a series left out)"
    out = Path(out)
    stem = out.name.removesuffix(".json").removesuffix("_statistics")
    out.parent.mkdir(parents=True, exist_ok=True)
    written = {"json": out.with_suffix(".json"), "tables": out.parent / f"{stem}_tables.md"}
    written["json"].write_text(json.dumps(document, indent=1) + "\n")
    written["tables"].write_text(claims_markdown(document))
    for name, plot in (("proportions", plot_claim_proportions), ("differences", plot_claim_differences)):
        path = plot(document, out.parent / f"{stem}_{name}.png")
        if path is not None:
            written[name] = path
    return written


CLAIMS_BEGIN, CLAIMS_END = "<!-- claims: begin", "<!-- claims: end -->"


def update_claims_block(document: Path, statistics: dict) -> None:
    """Replace the claims block of ``document`` (docs/RESULTS.md: between its begin and end markers) with the one
    generated from ``statistics``; ValueError when the document has not exactly one block."""
    text = document.read_text()
    if text.count(CLAIMS_BEGIN) != 1 or text.count(CLAIMS_END) != 1:
        raise ValueError(f"{document} must hold exactly one '{CLAIMS_BEGIN} ...' ... '{CLAIMS_END}' block")
    start = text.index("\n", text.index(CLAIMS_BEGIN)) + 1
    document.write_text(text[:start] + claims_block(statistics) + text[text.index(CLAIMS_END, start):])


def main(argv: list[str] | None = None) -> int:
    from fic_teleop_experiments.claims import SEEDS

    parser = argparse.ArgumentParser(description="The claim sweep's statistics, tables and figures")
    parser.add_argument("source", type=Path, nargs="?", default=None,
                        help="the judged sweep (default results/claims.json) or a run file of JSON lines")
    parser.add_argument("--out", type=Path, default=None,
                        help="the statistics' JSON (default: <source's folder>/<source's stem>_statistics.json)")
    parser.add_argument("--seeds-planned", type=int, default=SEEDS, help=f"seeds a cell is planned to have ({SEEDS})")
    parser.add_argument("--block", type=Path, default=None, metavar="STATISTICS_JSON",
                        help="print the claims block of docs/RESULTS.md from a statistics JSON written earlier, "
                             "and nothing else")
    parser.add_argument("--update-results", type=Path, default=None, metavar="RESULTS_MD",
                        help="also rewrite the claims block of this document (docs/RESULTS.md) from the new "
                             "statistics (after a new --judge)")
    parser.add_argument("--tail-start", type=Path, default=None, metavar="CLASSIFICATION_JSON",
                        help="keep only the runs whose quiet tail begins as --tail-begins says, by this file of "
                             "fic_teleop_experiments.tail_start (the stem gets _on_obstacle or _off_obstacle)")
    parser.add_argument("--tail-begins", choices=("off-obstacle", "on-obstacle"), default="off-obstacle")
    args = parser.parse_args(argv)
    if args.block is not None:
        print(claims_block(json.loads(args.block.read_text())), end="")
        return 0
    source = args.source or Path(os.environ.get("FIC_TELEOP_ROOT") or Path.cwd()) / "results" / "claims.json"
    if not source.is_file():
        parser.error(f"no judged sweep at {source} (scripts/experiments.sh claims --judge writes it)")
    stem = source.name.removesuffix(".jsonl").removesuffix(".json").removesuffix("_runs")
    tail_start = None
    if args.tail_start is not None:
        if not args.tail_start.is_file():
            parser.error(f"no tail-start classification at {args.tail_start} (fic_teleop_experiments.tail_start)")
        tail_start = (args.tail_start, args.tail_begins == "on-obstacle")
        stem += "_" + args.tail_begins.replace("-", "_")
    written = write_claims_statistics(source, args.out or source.parent / f"{stem}_statistics.json",
                                      args.seeds_planned, tail_start)
    for name, path in written.items():
        print(f"{name}: {path}")
    if args.update_results is not None:
        try:
            update_claims_block(args.update_results, json.loads(written["json"].read_text()))
        except (OSError, ValueError) as error:
            parser.error(str(error))
        print(f"results: {args.update_results} (its claims block)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
