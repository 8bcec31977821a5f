#!/usr/bin/env bash
# The main job beside a neighbour, placed (--cpu-placement profile) and left to the scheduler, alternated:
#   results/bench_cpu_placement_20261207/neighbour.sh busy|census ROUNDS
# busy: a 3 s busy loop in its own session; census: the graph census (a ROS participant listing the graph, as a
# user's `ros2 topic list`); each at +10 s and +20 s after the launcher wrote run.json.
set -u
kind="$1"; rounds="$2"
cd "$(dirname "$0")/../.." && source scripts/env.sh
work=$(mktemp -d)
neighbour() {   # $1: the run folder
  if [[ $kind == busy ]]; then
    setsid python3 -c "import time; e = time.time() + 3
while time.time() < e: pass" &
  else
    domain=$(python3 -c "import json; print(json.load(open('$1/run.json'))['domain_id'])")
    setsid python -m fic_teleop_experiments.tools.graph_census --domain "$domain" --out "$1.census.json" \
      > /dev/null 2>&1 &
  fi
}
for r in $(seq 1 "$rounds"); do
  for arm in profile none; do
    out=$work/$arm-$r
    ( /usr/bin/time -f "%U %S" -o "$out.time" scripts/run_teleop.sh --no-video --cpu-placement $arm --out "$out" \
        > "$out.log" 2>&1; echo $? > "$out.rc" ) &
    for _ in $(seq 1 200); do [ -f "$out/run.json" ] && break; sleep 0.1; done
    sleep 10; neighbour "$out"
    sleep 10; neighbour "$out"
    wait
    cpu=$(awk 'END { print $1 + $2 }' "$out.time")
    figures=$(python3 -c "import json; m = json.load(open('$out/report/metrics.json'))
print(round(m['pipeline_latency_p99_ms'], 2), round(m['free_motion_error_max_m'] * 1000, 1))" 2>/dev/null)
    echo "$arm $r exit $(cat "$out.rc") cpu $cpu p99/error max $figures;" \
      "$(grep -o 'replica loop: [0-9]* holds[^,]*' "$out.log") $(grep -o 'tick gap max [0-9.]* ms' "$out.log");" \
      "$(grep -o 'slowest loop .* of its rate' "$out.log")"
  done
done
