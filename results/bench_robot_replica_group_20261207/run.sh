#!/usr/bin/env bash
# usage: run.sh N -- the default groups (D) against the robot and the replica in one process (G), then two stations
# as they are (T) and with the two grouped (TG, two_stations_grouped.yaml beside this file), N alternated rounds
# each (scripts/ab_main_job.sh); results.txt is the 2026-12-07 run of `run.sh 3` (D, G) and 2 rounds of T, TG.
here="$(cd "$(dirname "$0")" && pwd)"
ab="$here/../../scripts/ab_main_job.sh"
"$ab" "$1" "D=." "G=.:--group robot,replica --group channel_forward,channel_backward --group haptic_device,master"
"$ab" "$1" "T=.:--two-stations" "TG=.:--two-stations --profile $here/two_stations_grouped.yaml"
