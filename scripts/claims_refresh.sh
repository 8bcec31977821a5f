#!/usr/bin/env bash
# Bring a claim sweep's judged figures up to date while it runs, or once it has ended (docs/EXPERIMENTS.md, "Claims"):
#   scripts/claims_refresh.sh [COMMIT] [NAME]       (COMMIT: default the tag claims-tail-v3; NAME: claims_tail_v3)
# 1. judges the runs of results/NAME_runs.jsonl that have no verdict yet, on the sweep's own code (the snapshot
#    scripts/claims_background.sh made of COMMIT), into results/NAME.json; every earlier verdict is kept;
# 2. from this checkout: where each run's quiet tail begins (results/NAME_tail_start.json; a series lost with a machine
#    keeps its earlier class), the statistics, tables and plots of all runs and of the tails begun off and on the
#    obstacle, and docs/RESULTS.md's claims block (checked by test/experiments/test_readme_results.py).
# README's and RESULTS' hand-written counts are not touched: the test above names each one that no longer matches.
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
COMMIT="$(git -C "$REPO" rev-parse "${1:-claims-tail-v3}")"
NAME="${2:-claims_tail_v3}"
[[ -f "$REPO/runs/claims_snapshot_${COMMIT:0:12}/COMMIT" ]] || {
  echo "no snapshot of $COMMIT: scripts/claims_background.sh makes it when the sweep starts" >&2; exit 2; }
cd "$REPO"
(
  # shellcheck source=scripts/claims_snapshot.sh
  source "$REPO/scripts/claims_snapshot.sh"
  nice -n 10 python "${sweep[@]}" --no-progress --judge --workers 1 \
    --out-dir "$REPO/results/${NAME}_runs" --jsonl "$REPO/results/${NAME}_runs.jsonl" \
    --summary "$REPO/results/$NAME.json" --reuse-verdicts "$REPO/results/$NAME.json"
)
# shellcheck source=/dev/null
source "$REPO/scripts/env.sh"
python -m fic_teleop_experiments.tail_start "results/$NAME.json" --series "results/${NAME}_runs" \
  --out "results/${NAME}_tail_start.json"
python -m fic_teleop_experiments.claims_report "results/$NAME.json" --update-results docs/RESULTS.md
for where in off-obstacle on-obstacle; do
  python -m fic_teleop_experiments.claims_report "results/$NAME.json" --tail-start "results/${NAME}_tail_start.json" \
    --tail-begins "$where"
done
python -m pytest -q -p no:cacheprovider test/experiments/test_readme_results.py || {
  echo "claims refresh: the figures above no longer match README or RESULTS; update them and run the test again" >&2
  exit 1
}
