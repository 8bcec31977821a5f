#!/usr/bin/env bash
# The paper's experiments E1-E4 (docs/EXPERIMENTS.md) on the real graph, in lockstep unless told otherwise, with a
# progress bar; results (JSON + PNG) to results/. `--quick` runs two short E4 cells; `--help` lists the options.
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$REPO/scripts/setup.sh"
# shellcheck source=/dev/null
source "$REPO/scripts/env.sh"
# `claims`: the claim cells on the in-process runner (fic_teleop_experiments.claims_sweep; docs/EXPERIMENTS.md
# "Claims"). Otherwise E1-E4 on the graph (fic_teleop_experiments.paper_experiments).
if [[ "${1:-}" == "claims" ]]; then shift; exec python -m fic_teleop_experiments.claims_sweep "$@"; fi
exec python -m fic_teleop_experiments.paper_experiments "$@"
