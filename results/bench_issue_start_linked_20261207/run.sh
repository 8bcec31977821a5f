#!/usr/bin/env bash
# usage: run.sh N CLONE_5D7EA60 CLONE_66D88EE [CLONE_GC] -- the main job of 5d7ea60 (2026-12-04 22:53), of 66d88ee
# (where the work on real time with headroom began, 2026-12-05 19:24) and of this checkout (the robot and the replica
# linked in one process), N alternated rounds; each clone set up by its own scripts/setup.sh. CLONE_GC (optional):
# this checkout with gc.collect() + gc.freeze() after the nodes are built (fic_teleop_runtime/node_main.py), the
# lever tried beside them. versus.json is the 2026-12-07 afternoon run of `run.sh 3` with all four.
here="$(cd "$(dirname "$0")" && pwd)"
arms=("B5D=$2" "S66=$3" "HEAD=.")
[[ -n "${4:-}" ]] && arms+=("GC=$4")
exec "$here/../../scripts/bench.sh" --versus "${arms[@]}" --runs "$1" --out "$here/versus.json"
