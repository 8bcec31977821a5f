#!/usr/bin/env bash
# Benchmarks (docs/EXPERIMENTS.md, "Benchmarks"): replica tick compute, the default main job (timed; pipeline latency, real-time
# factor, realtime step lateness, CPU and peak RSS per node) and lockstep steps per second; prints a table and
# writes results/bench.json. `--stress 150,100,70,50 --runs N`: the starvation harness per CPU level instead
# (results/stress.json, needs root). `--help` lists the options.
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$REPO/scripts/setup.sh"
# shellcheck source=/dev/null
source "$REPO/scripts/env.sh"
exec python -m fic_teleop_experiments.tools.bench "$@"
