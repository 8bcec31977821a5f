"""Re-simulate kept claim runs and check them bit for bit against their run lines and series (docs/EXPERIMENTS.md
"Claims"): what shows that a commit may take over a sweep another commit started.

For each key: the run line (the last one of that key in ``--jsonl``) gives the run; it is simulated again with the
code this process imports (claims.execute into a scratch directory) and compared with what was kept: every array of
the kept series with ``numpy.array_equal`` (NaN equal to NaN; the run's wall time aside), the draws and the operator's
moves, and every figure of the row with ``==``; fields the kept series lacks (recorded only by a later commit) are
named, not counted as differences. Exit status 0 when every key is identical, 1 otherwise.

    python -m fic_teleop_experiments.claims_reproduce delay_0__rate_5__linear__reactive__4__30s ...
    python -m fic_teleop_experiments.claims_reproduce --commit 6018e3d65d09 --cells 3   # 3 keys of different cells
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from fic_teleop_experiments.claims import ClaimRun, execute
from fic_teleop_runtime.workspace import working_folder

REPO = working_folder()   # runs/ and results/ (FIC_TELEOP_ROOT, else the current folder)
CLAIM_FIELDS = ("delay", "rate_hz", "controller", "hand", "seed", "duration", "force_feedback", "tail")


def run_lines(jsonl: Path) -> dict[str, dict[str, Any]]:
    """The last run line of every key (a line cut short by a kill is skipped)."""
    rows: dict[str, dict[str, Any]] = {}
    for line in jsonl.read_text().splitlines():
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue
        rows[row["key"]] = row
    return rows


def one_key_a_cell(rows: dict[str, dict[str, Any]], commit: str, cells: int) -> list[str]:
    """The first key of each of the first ``cells`` cells run by ``commit`` (a prefix of it), in line order."""
    keys: dict[str, str] = {}
    for key, row in rows.items():
        if str(row.get("commit") or "").startswith(commit) and row["cell"] not in keys:
            keys[row["cell"]] = key
    return list(keys.values())[:cells]


def differences(kept: Path, fresh: Path, row: dict[str, Any], again: dict[str, Any]) -> tuple[list[str], list[str]]:
    """What differs between a kept run (its series and row) and the same run simulated again, and the series fields
    only the new simulation records (added by a later commit)."""
    out = []
    with np.load(kept) as old, np.load(fresh) as new:
        added = sorted(set(new.files) - set(old.files))
        # A field the kept series lacks was recorded only since (a newer commit records more); one the new series
        # lacks is a difference: what the kept run showed can no longer be compared.
        if set(old.files) - set(new.files):
            out.append(f"series fields no longer recorded {sorted(set(old.files) - set(new.files))}")
        for name in sorted(set(old.files) & set(new.files) - {"wall_s"}):   # the wall time is the machine's
            a, b = old[name], new[name]
            equal = np.array_equal(a, b, equal_nan=a.dtype.kind == "f" and b.dtype.kind == "f")
            if not equal:
                out.append(f"series {name}")
    if again["draws"] != row["draws"]:
        out.append("draws")
    for name, value in row["figures"].items():
        if again["figures"].get(name) != value:
            out.append(f"figure {name}: {value!r} then, {again['figures'].get(name)!r} now")
    return out, added


def reproduce(key: str, row: dict[str, Any], directory: Path,
              scratch: Path) -> tuple[list[str], list[str], float, float]:
    """(the differences, the fields recorded only since, the wall time and the CPU time [s] of the new simulation
    and its saving) for one kept run."""
    claim = ClaimRun(**{name: row[name] for name in CLAIM_FIELDS if name in row})   # older lines: feedback on
    if claim.key != key:
        raise ValueError(f"the run line of {key} describes {claim.key}")
    cpu = time.process_time()
    again = execute(claim, scratch)
    cpu = time.process_time() - cpu
    found, added = differences(directory / row["series"], scratch / f"{key}.npz", row, again)
    return found, added, again["wall_total_s"], cpu


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("keys", nargs="*", help="claim keys (their run lines in --jsonl, their series in --out-dir)")
    parser.add_argument("--commit", default=None, help="with --cells: keys of runs this commit (a prefix) made")
    parser.add_argument("--cells", type=int, default=3, help="with --commit: one key from each of this many cells")
    parser.add_argument("--jsonl", type=Path, default=REPO / "results" / "claims_runs.jsonl")
    parser.add_argument("--out-dir", type=Path, default=REPO / "results" / "claims_runs")
    args = parser.parse_args(argv)
    rows = run_lines(args.jsonl)
    keys = list(args.keys) + (one_key_a_cell(rows, args.commit, args.cells) if args.commit else [])
    if not keys:
        parser.error("name keys, or --commit")
    unknown = [key for key in keys if key not in rows]
    if unknown:
        parser.error(f"no run line for {', '.join(unknown)} in {args.jsonl}")
    failed = 0
    with tempfile.TemporaryDirectory() as scratch:
        for key in keys:
            found, added, wall, cpu = reproduce(key, rows[key], args.out_dir, Path(scratch))
            failed += bool(found)
            print(f"{key} (commit {str(rows[key].get('commit'))[:12]}): "
                  + ("identical" if not found else "DIFFERS in " + "; ".join(found))
                  + (f" (fields recorded only since: {', '.join(added)})" if added else "")
                  + f" [{wall:.1f} s wall, {cpu:.1f} s CPU; {rows[key]['wall_s']:.1f} s wall then]", flush=True)
    print(f"{len(keys) - failed} of {len(keys)} runs identical")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
