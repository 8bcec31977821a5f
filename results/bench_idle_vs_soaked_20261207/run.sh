#!/usr/bin/env bash
# usage: run.sh N -- the main job on an idle machine (Q) against the same main job with two busy loops beside it at 2
# of 1024 CPU shares (S: the machine soaked, as 2026-12-06's 37.2-40.2 CPU-s were measured beside other work), N
# alternated rounds, each run by `scripts/bench.sh --versus` (one JSON a run beside this file). Needs root (a cgroup v1
# cpu controller) for the busy loops' weight; results.txt is the 2026-12-07 run of `run.sh 3`.
set -uo pipefail   # a starved run (exit 6) is a result here, not a reason to stop
here="$(cd "$(dirname "$0")" && pwd)"
bench="$here/../../scripts/bench.sh"
group=/sys/fs/cgroup/cpu/fic_soak
mkdir -p "$group" && echo 2 > "$group/cpu.shares" || exit 1
soak() { for _ in 1 2; do sh -c "echo \$\$ > $group/cgroup.procs; exec python3 -c 'while True: pass'" & done; }
for i in $(seq "$1"); do
  "$bench" --versus "Q=." --runs 1 --out "$here/Q-$i.json" | grep "^Q 1 " | sed "s/^Q 1/Q $i/" | tee -a "$here/results.txt"
  soak
  "$bench" --versus "S=." --runs 1 --out "$here/S-$i.json" | grep "^S 1 " | sed "s/^S 1/S $i/" | tee -a "$here/results.txt"
  pkill -f "while True: pass" || true
  sleep 2
done
