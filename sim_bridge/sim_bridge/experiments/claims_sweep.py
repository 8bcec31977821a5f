"""Running the claim runs through an executor, keeping each as it finishes, and resuming (docs/EXPERIMENTS.md "Claims").

``sweep`` submits every run not done yet to a concurrent.futures.Executor (a process pool over this machine's cores,
or a Dask cluster's: sim_bridge.experiments.engine), appends each finished run's row to a JSON-lines file and keeps
its series beside it (claims.execute); ``finished`` reads back what is done, so a sweep stopped anywhere resumes where
it stopped; ``judged`` applies the run verdict to the kept series.
"""
from __future__ import annotations

import json
from concurrent.futures import Executor, as_completed
from pathlib import Path

from tqdm import tqdm

from sim_bridge.experiments.claims import ClaimRun, execute, judge_series


def finished(jsonl: Path, directory: Path) -> dict[str, dict]:
    """The rows of runs already done: a line in ``jsonl`` whose series file is in ``directory`` (the last line of a
    key wins; a line cut short by a kill is ignored)."""
    rows: dict[str, dict] = {}
    if jsonl.exists():
        for line in jsonl.read_text().splitlines():
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue
            if (directory / row["series"]).exists():
                rows[row["key"]] = row
    return rows


def sweep(runs: list[ClaimRun], executor: Executor, directory: Path, jsonl: Path, source: dict,
          progress: bool = True) -> tuple[list[dict], list[dict]]:
    """Run what is not done yet through ``executor``, appending each row to ``jsonl`` as it finishes. Returns (the
    rows of ``runs``, the rows simulated now)."""
    done = finished(jsonl, directory)
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


def judged(rows: list[dict], directory: Path, executor: Executor, progress: bool = True) -> list[dict]:
    """Every row with the run verdict of its kept series (``verdict``)."""
    futures = {executor.submit(judge_series, directory / row["series"], row["delay"]): row for row in rows}
    out = []
    for future in tqdm(as_completed(futures), total=len(futures), unit="run", disable=not progress,
                       desc="verdicts", mininterval=5.0):
        out.append({**futures[future], "verdict": future.result()})
    return sorted(out, key=lambda row: row["key"])
