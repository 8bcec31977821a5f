#!/usr/bin/env bash
# usage: run.sh N OLD_CHECKOUT -- the main job of a clone at f8bb082 (set up by its own scripts/setup.sh) against this
# checkout's, N alternated rounds (scripts/ab_main_job.sh); results.txt is the 2026-12-07 05:30 run of `run.sh 4`.
exec "$(dirname "$0")/../../scripts/ab_main_job.sh" "$1" "OLD=$2" "NEW=."
