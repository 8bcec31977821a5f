"""Bring a claim sweep's judged figures up to date while it runs, or once it has ended (docs/EXPERIMENTS.md, "Claims").

    python -m fic_teleop_experiments.claims_refresh [COMMIT] [NAME]     (COMMIT: the tag claims-tail-v3; NAME:
                                                                        claims_tail_v3)
1. judges the runs of results/NAME_runs.jsonl that have no verdict yet, on the sweep's own code (the snapshot
   scripts/claims_background.sh made of COMMIT, claims_snapshot.py), into results/NAME.json; every earlier verdict
   is kept;
2. from this checkout: where each run's quiet tail begins (results/NAME_tail_start.json; a series lost with a machine
   keeps its earlier class), the statistics, tables and plots of all runs and of the tails begun off and on the
   obstacle, and docs/RESULTS.md's claims block;
3. test/experiments/test_readme_results.py, which names each hand-written count of README and RESULTS that no longer
   matches (they are not touched here): exit 1 then.
"""
from __future__ import annotations

import argparse
import subprocess
import sys

from fic_teleop_experiments.claims_snapshot import resolve, snapshot_folder
from fic_teleop_runtime.workspace import working_folder


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("commit", nargs="?", default="claims-tail-v3", help="the sweep's commit or tag")
    parser.add_argument("name", nargs="?", default="claims_tail_v3", help="its results' name in results/")
    args = parser.parse_args(argv)
    repo = working_folder()
    try:
        commit = resolve(repo, args.commit)
    except subprocess.CalledProcessError:
        parser.error(f"{args.commit!r} is no commit of {repo}")
    if not (snapshot_folder(repo, commit) / "COMMIT").is_file():
        print(f"no snapshot of {commit}: scripts/claims_background.sh makes it when the sweep starts", file=sys.stderr)
        return 2
    results, name = repo / "results", args.name
    judged, runs = results / f"{name}.json", results / f"{name}_runs"

    def run(*command: str) -> int:
        return subprocess.run(list(command), cwd=repo).returncode

    steps = [
        ["nice", "-n", "10", sys.executable, "-m", "fic_teleop_experiments.claims_snapshot", commit, "--no-progress",
         "--judge", "--workers", "1", "--out-dir", str(runs), "--jsonl", str(results / f"{name}_runs.jsonl"),
         "--summary", str(judged), "--reuse-verdicts", str(judged)],
        [sys.executable, "-m", "fic_teleop_experiments.tail_start", str(judged), "--series", str(runs),
         "--out", str(results / f"{name}_tail_start.json")],
        [sys.executable, "-m", "fic_teleop_experiments.claims_report", str(judged), "--update-results",
         str(repo / "docs" / "RESULTS.md")],
        *([sys.executable, "-m", "fic_teleop_experiments.claims_report", str(judged), "--tail-start",
           str(results / f"{name}_tail_start.json"), "--tail-begins", where] for where in ("off-obstacle",
                                                                                         "on-obstacle")),
    ]
    for step in steps:
        code = run(*step)
        if code:
            print(f"claims refresh: {' '.join(step[:6])} ... exited {code}", file=sys.stderr)
            return code
    if run(sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test/experiments/test_readme_results.py"):
        print("claims refresh: the figures above no longer match README or RESULTS; update them and run the test "
              "again", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
