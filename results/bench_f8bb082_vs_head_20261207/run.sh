#!/usr/bin/env bash
# usage: run.sh N OLD_CHECKOUT -- the main job of a clone at f8bb082 (set up by its own scripts/setup.sh) against this
# checkout's, N alternated rounds (scripts/bench.sh --versus); results.txt is the 2026-12-07 05:30 run of `run.sh 4`,
# printed by the alternating script bench --versus replaced (the same runs and figures, one line each).
here="$(cd "$(dirname "$0")" && pwd)"
exec "$here/../../scripts/bench.sh" --versus "OLD=$2" "NEW=." --runs "$1" --out "$here/versus.json"
