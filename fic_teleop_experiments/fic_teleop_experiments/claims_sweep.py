"""Running the claim runs through an executor, keeping each as it finishes, and resuming (docs/EXPERIMENTS.md "Claims").

``sweep`` submits every run not done yet to a concurrent.futures.Executor (a process pool over this machine's cores,
or a Dask cluster's: fic_teleop_experiments.engine), appends each finished run's row to a JSON-lines file and keeps
its series beside it (claims.execute); ``finished`` reads back what is done, so a sweep stopped anywhere resumes where
it stopped; ``judged`` applies the run verdict to the kept series.

The command line runs the claim cells (fic_teleop_experiments.claims): channels at full rate, 10 and 5 Hz both
ways, one-way delay 0, 0.2, 1 and 2 s (and 0.5, 1.5 s at full rate), the closed-loop operator with a passive or a
force-reactive hand, a task drawn per seed, every law; most important cells first. Each finished run's series goes
to <out-dir>/<key>.npz and its row (config, seed, wall time, figures, commit) to one line of <jsonl>, as it
finishes; a re-run skips every run whose line and series are both there. ``--judge`` applies the run verdict
(fic_teleop_tools.verdict.run_verdict) to every kept series and writes <summary>.json: one record per run with its
row and both verdicts. ``--judge --reuse-verdicts <summary>`` takes a run's verdict from an earlier summary instead
of judging it again when that summary was judged by the same verdict code (``verdict_code``: a hash of the sources a
verdict depends on) and the run's row is the same; the rest are judged (a sweep judged while it ran, then its last
runs, gives what one judgement of the finished sweep gives).

    scripts/experiments.sh claims --quick              # 2 cells x 5 laws x 2 hands, 1 seed, 10 s
    scripts/experiments.sh claims                      # the full sweep (3600 runs), all local cores
    scripts/experiments.sh claims --limit 40           # the next 40 runs only
    scripts/experiments.sh claims --judge              # verdicts on what is kept -> results/claims.json
    scripts/experiments.sh claims --cluster tcp://host:8786   # on a Dask cluster (docs/CLUSTER.md)

(``scripts/experiments.sh claims ...`` is ``python -m fic_teleop_experiments.claims_sweep ...`` in the workspace.)
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from concurrent.futures import Executor, as_completed
from pathlib import Path
from typing import Callable

from tqdm import tqdm

from fic_teleop_experiments.claims import CONTROLLERS, SEEDS, ClaimRun, claim_runs, execute, judge_series, provenance
from fic_teleop_experiments.engine import add_engine_arguments, engine_from_arguments
from fic_teleop_experiments.in_process import HANDS
from fic_teleop_runtime.workspace import working_folder

REPO = working_folder()   # runs/ and results/ (FIC_TELEOP_ROOT, else the current folder)


def verdict_holds(earlier: dict | None, row: dict) -> bool:
    """Whether ``earlier`` (a judged row) is ``row`` with its verdict: the run unchanged, so its verdict stands."""
    return earlier is not None and {k: v for k, v in earlier.items() if k != "verdict"} == row


def finished(jsonl: Path, directory: Path, judged_rows: dict[str, dict] | None = None) -> dict[str, dict]:
    """The rows of runs already done: a line in ``jsonl`` whose series file is in ``directory``, or whose verdict
    ``judged_rows`` holds for the same row (judged by this verdict code: its series is no longer needed, and a series
    lost with a machine is not simulated again). The last line of a key wins; a line cut short by a kill is
    ignored."""
    judged_rows = judged_rows or {}
    rows: dict[str, dict] = {}
    if jsonl.exists():
        for line in jsonl.read_text().splitlines():
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue
            if verdict_holds(judged_rows.get(row.get("key")), row) or (directory / row["series"]).exists():
                rows[row["key"]] = row
    return rows


def sweep(runs: list[ClaimRun], executor: Executor, directory: Path, jsonl: Path, source: dict,
          progress: bool = True, judged_rows: dict[str, dict] | None = None) -> tuple[list[dict], list[dict]]:
    """Run what is not done yet (``finished``) through ``executor``, appending each row to ``jsonl`` as it finishes.
    Returns (the rows of ``runs``, the rows simulated now)."""
    done = finished(jsonl, directory, judged_rows)
    pending = [claim for claim in runs if claim.key not in done]
    jsonl.parent.mkdir(parents=True, exist_ok=True)
    directory.mkdir(parents=True, exist_ok=True)
    futures = {executor.submit(execute, claim, str(directory), source): claim for claim in pending}
    bar = tqdm(total=len(runs), initial=len(runs) - len(pending), unit="run", disable=not progress,
               dynamic_ncols=True, mininterval=5.0)
    new = []
    with jsonl.open("a") as out:
        for future in as_completed(futures):
            row = future.result()
            new.append(row)
            out.write(json.dumps(row) + "\n")
            out.flush()
            done[row["key"]] = row
            figures = row["figures"]
            bar.set_postfix_str(f"{row['key']}: {figures['error_rms_m'] * 1e3:.0f} mm rms, "
                                f"{figures['peak_force_n']:.0f} N, {row['simulated_s'] / row['wall_s']:.2f} x",
                                refresh=False)
            bar.update(1)
            if not progress:   # a log: one line a run
                print(f"[{len(done)}/{len(runs)}] {row['key']}: {figures['error_rms_m'] * 1e3:.1f} mm rms, "
                      f"{figures['peak_force_n']:.1f} N, {row['wall_total_s']:.0f} s wall", flush=True)
    bar.close()
    return [done[claim.key] for claim in runs if claim.key in done], new


def verdict_code() -> str:
    """A hash of the sources a claim run's verdict depends on: the run verdict's package, the Panda's limits it judges
    against and the code that loads a kept series (claims.py, with judge_series)."""
    import fic_core.arm_profile
    import fic_teleop_experiments.claims
    import fic_teleop_tools.verdict

    files = sorted(Path(fic_teleop_tools.verdict.__file__).resolve().parent.glob("*.py"))
    files += [Path(fic_core.arm_profile.__file__).resolve(), Path(fic_teleop_experiments.claims.__file__).resolve()]
    digest = hashlib.sha256()
    for path in files:
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def reusable(summary: Path | None, code: str) -> dict[str, dict]:
    """The judged rows of an earlier ``summary`` by key, when it was judged by the verdict ``code``; else none."""
    if summary is None or not summary.exists():
        return {}
    document = json.loads(summary.read_text())
    if document.get("verdict_code") != code:
        return {}
    return {row["key"]: row for row in document.get("runs", []) if "verdict" in row}


def judged(rows: list[dict], directory: Path, executor: Executor, progress: bool = True,
           earlier: dict[str, dict] | None = None, checkpoint: Callable[[list[dict]], None] | None = None,
           every: float = 120.0) -> list[dict]:
    """Every row with the run verdict of its kept series (``verdict``); a row ``earlier`` holds unchanged (its verdict
    from the same verdict code) keeps that verdict. ``checkpoint``, when given, receives every ``every`` seconds the
    rows judged so far and the rest without a verdict (so that a judgement stopped anywhere resumes from it)."""
    earlier = earlier or {}
    out, pending = [], []
    for row in rows:
        before = earlier.get(row["key"])
        if verdict_holds(before, row):
            out.append(before)
        else:
            pending.append(row)
    futures = {executor.submit(judge_series, directory / row["series"], row["delay"]): row for row in pending}
    waiting = {row["key"]: row for row in pending}
    last = time.monotonic()
    for future in tqdm(as_completed(futures), total=len(futures), unit="run", disable=not progress,
                       desc="verdicts", mininterval=5.0):
        row = futures[future]
        out.append({**row, "verdict": future.result()})
        del waiting[row["key"]]
        if checkpoint is not None and time.monotonic() - last >= every:
            checkpoint(sorted(out + list(waiting.values()), key=lambda r: r["key"]))
            last = time.monotonic()
    return sorted(out, key=lambda row: row["key"])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="the two 1 s cells (10 Hz and full rate), 1 seed, 10 s runs, into results/claims_quick*")
    parser.add_argument("--seeds", type=int, default=None, help=f"seeds a cell (default {SEEDS}; --quick 1)")
    parser.add_argument("--duration", type=float, default=None,
                        help="run length [s] (default: 30 s, longer beyond 1 s delay; --quick 10 s)")
    parser.add_argument("--controllers", nargs="+", default=list(CONTROLLERS), choices=CONTROLLERS)
    parser.add_argument("--hands", nargs="+", default=list(HANDS), choices=HANDS)
    parser.add_argument("--cells", nargs="+", default=None,
                        help="only these cells (their names, e.g. delay_1__rate_10__feedback_off); default every cell")
    parser.add_argument("--limit", type=int, default=None, help="run at most this many of the runs not done yet")
    parser.add_argument("--out-dir", type=Path, default=None, help="series directory (default results/claims_runs)")
    parser.add_argument("--jsonl", type=Path, default=None, help="run log (default results/claims_runs.jsonl)")
    parser.add_argument("--judge", action="store_true",
                        help="no new runs: apply the run verdict to every kept run and write --summary")
    parser.add_argument("--summary", type=Path, default=None, help="judged runs (default results/claims.json)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar (a log file)")
    parser.add_argument("--reuse-verdicts", type=Path, default=None, metavar="SUMMARY",
                        help="keep the verdicts of an earlier summary judged by the same verdict code for runs whose "
                             "row is unchanged (with --judge: judge the rest; without: those runs count as done even "
                             "if their series is gone)")
    parser.add_argument("--checkpoint", action="store_true",
                        help="with --judge: write --summary every 2 min with the runs judged so far (the rest without "
                             "a verdict); --reuse-verdicts on the same file resumes a stopped judgement")
    add_engine_arguments(parser)
    args = parser.parse_args(argv)
    stem = "claims_quick" if args.quick else "claims"
    directory = args.out_dir or REPO / "results" / f"{stem}_runs"
    jsonl = args.jsonl or REPO / "results" / f"{stem}_runs.jsonl"
    summary = args.summary or REPO / "results" / f"{stem}.json"
    runs = claim_runs(args.seeds or (1 if args.quick else SEEDS), args.controllers, args.hands, args.quick,
                      args.duration or (10.0 if args.quick else None))
    if args.cells:
        known = {claim.cell for claim in runs}
        unknown = sorted(set(args.cells) - known)
        if unknown:
            parser.error(f"--cells: no such cell {', '.join(unknown)} (cells: {', '.join(sorted(known))})")
        runs = [claim for claim in runs if claim.cell in args.cells]
    progress = not args.no_progress
    with engine_from_arguments(args) as engine:
        code = verdict_code()
        earlier = reusable(args.reuse_verdicts, code)
        if args.reuse_verdicts is not None and not earlier:
            print(f"{args.reuse_verdicts}: no verdicts of this verdict code ({code}) to reuse", flush=True)
        if args.judge:
            rows = list(finished(jsonl, directory, earlier).values())
            start = time.perf_counter()

            def document_of(judged_rows: list[dict]) -> dict:
                # runs_planned: the sweep's runs for these options; fewer judged runs: the sweep (or the judgement)
                # had not finished.
                return dict(runs_planned=len(runs), runs_judged=sum(1 for r in judged_rows if "verdict" in r),
                            runs=judged_rows, verdict_code=code,
                            verdicts_reused=sum(1 for r in judged_rows if earlier.get(r["key"]) is r),
                            engine=engine.describe(), judged_at=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                            **provenance(REPO))

            def write(document: dict) -> None:
                summary.parent.mkdir(parents=True, exist_ok=True)
                partial = summary.with_name(summary.name + ".part")
                partial.write_text(json.dumps(document, indent=1))
                partial.replace(summary)

            judged_rows = judged(rows, directory, engine.executor, progress, earlier,
                                 checkpoint=(lambda so_far: write(document_of(so_far))) if args.checkpoint else None)
            document = document_of(judged_rows)
            reused = document["verdicts_reused"]
            print(f"{len(rows) - reused} runs judged in {time.perf_counter() - start:.0f} s of wall time"
                  + (f", {reused} verdicts reused from {args.reuse_verdicts}" if reused else ""), flush=True)
            write(document)
            counts = [(r["verdict"]["stable"], r["verdict"]["safe"]) for r in document["runs"]]
            print(f"{len(counts)} runs judged -> {summary}: {sum(s is True for s, _ in counts)} stable, "
                  f"{sum(s is None for s, _ in counts)} not assessed, {sum(safe for _, safe in counts)} safe")
            return 0
        done = finished(jsonl, directory, earlier)
        pending = [claim.key for claim in runs if claim.key not in done]
        if args.limit is not None:   # the first ``limit`` runs not done yet, beside those done
            keep = set(pending[:args.limit])
            runs = [claim for claim in runs if claim.key in done or claim.key in keep]
            pending = pending[:args.limit]
        source = {**provenance(REPO), "engine": engine.name, "workers": engine.workers}
        print(f"{len(runs)} runs, {len(pending)} to simulate on {engine.workers} {engine.name} workers, commit "
              f"{source['commit']}" + (" (tracked files modified)" if source["tree_modified"] else ""), flush=True)
        start = time.perf_counter()
        rows, new = sweep(runs, engine.executor, directory, jsonl, source, progress, earlier)
        wall = time.perf_counter() - start
    if new:
        print(f"{len(new)} runs in {wall:.0f} s of wall time: {3600.0 * len(new) / wall:.0f} runs per hour, "
              f"{sum(r['simulated_s'] for r in new) / wall:.2f} simulated s per wall s", flush=True)
    print(f"{len(rows)} of {len(runs)} runs kept in {directory} and {jsonl}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
