#!/usr/bin/env bash
# One run of the graph at a stated share of the CPU (fic_teleop_experiments/tools/stress.py): a cgroup CPU quota of LEVEL % of
# one CPU on the whole graph (or --node NAME alone), optional pinned CPU hogs; then the run's verdict and runaway
# figures as JSON (and <run>/stress.json). Needs root (cgroups). Per level, N runs: scripts/bench.sh --stress.
#   scripts/stress.sh 70 [--node replica] [--hogs 1 --hog-cpus 0] [--out runs/x] -- --duration 20 [--two-stations]
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$REPO/scripts/setup.sh"
# shellcheck source=/dev/null
source "$REPO/scripts/env.sh"
exec python -m fic_teleop_experiments.tools.stress "$@"
