#!/usr/bin/env bash
# usage: run.sh N -- the default main job with the robot and the replica linked in one process (LINKED, the default)
# against them apart over DDS (APART, apart.yaml beside this file), single host and two stations, N alternated
# rounds (scripts/bench.sh --versus); bench_versus.json and bench_versus.log are the record.
here="$(cd "$(dirname "$0")" && pwd)"
"$here/../../scripts/bench.sh" --versus "LINKED=." "APART=.:--profile $here/apart.yaml" \
  "LINKED_2ST=.:--two-stations" "APART_2ST=.:--two-stations --profile $here/apart_two_stations.yaml" \
  --runs "$1" --out "$here/bench_versus.json"
