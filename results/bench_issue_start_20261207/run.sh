#!/usr/bin/env bash
# usage: run.sh N CLONE_5D7EA60 CLONE_66D88EE -- the main job of 5d7ea60 (2026-12-04 22:53), of 66d88ee (the commit at
# which the work on real time with headroom began, 2026-12-05 19:24) and of this checkout, N alternated rounds; each
# clone set up by its own scripts/setup.sh. versus.json is the 2026-12-07 08:04 run of `run.sh 3` (the claim sweep
# stopped, nothing else running).
here="$(cd "$(dirname "$0")" && pwd)"
exec "$here/../../scripts/bench.sh" --versus "B5D=$2" "S66=$3" "HEAD=." --runs "$1" --out "$here/versus.json"
