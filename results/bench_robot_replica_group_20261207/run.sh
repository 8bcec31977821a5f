#!/usr/bin/env bash
# usage: run.sh N -- the default groups (D) against the robot and the replica in one process (G), then two stations
# as they are (T) and with the two grouped (TG, two_stations_grouped.yaml beside this file), N alternated rounds
# each (scripts/bench.sh --versus); results.txt is the 2026-12-07 run of `run.sh 3` (D, G) and 2 rounds of T, TG,
# printed by the alternating script bench --versus replaced (the same runs and figures, one line each).
here="$(cd "$(dirname "$0")" && pwd)"
bench="$here/../../scripts/bench.sh"
"$bench" --versus "D=." "G=.:--group robot,replica --group channel_forward,channel_backward --group haptic_device,master" \
  --runs "$1" --out "$here/versus_single_host.json"
"$bench" --versus "T=.:--two-stations" "TG=.:--two-stations --profile $here/two_stations_grouped.yaml" \
  --runs "$1" --out "$here/versus_two_stations.json"
