#!/usr/bin/env bash
# The claim sweep in the background, on a frozen copy of one commit (docs/EXPERIMENTS.md "Claims"):
#   scripts/claims_background.sh [COMMIT] [claims_sweep.py options...]     (COMMIT: default HEAD)
# exports COMMIT's tree (git archive) to runs/claims_snapshot_<commit>/ and runs its scripts/claims_sweep.py there,
# under nice -n 15, detached from the terminal (setsid nohup), logging to results/claims_runs.log, with its series
# and run lines in this checkout's results/claims_runs/ and results/claims_runs.jsonl. The code and the config are the
# commit's even while the checkout changes; every run line names that commit. Run it again (same COMMIT) to resume.
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
COMMIT="$(git -C "$REPO" rev-parse "${1:-HEAD}")"
[[ $# -gt 0 ]] && shift
SNAPSHOT="$REPO/runs/claims_snapshot_${COMMIT:0:12}"
if [[ ! -f "$SNAPSHOT/COMMIT" ]]; then
  mkdir -p "$SNAPSHOT"
  git -C "$REPO" archive "$COMMIT" | tar -x -C "$SNAPSHOT"
  echo "$COMMIT" > "$SNAPSHOT/COMMIT"
fi
# shellcheck source=/dev/null
source "$REPO/scripts/env.sh"
export PYTHONPATH="$SNAPSHOT/sim_bridge:$SNAPSHOT/fic_core${PYTHONPATH:+:$PYTHONPATH}"
mkdir -p "$REPO/results"
setsid nohup nice -n 15 python "$SNAPSHOT/scripts/claims_sweep.py" --no-progress \
  --out-dir "$REPO/results/claims_runs" --jsonl "$REPO/results/claims_runs.jsonl" "$@" \
  >> "$REPO/results/claims_runs.log" 2>&1 < /dev/null &
echo "claim sweep started: pid $!, commit $COMMIT, log $REPO/results/claims_runs.log"
