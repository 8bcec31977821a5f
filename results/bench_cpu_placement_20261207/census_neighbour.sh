#!/usr/bin/env bash
# A graph query beside the main job: the graph census (a ROS participant that lists the graph's nodes and topics, as a
# user's `ros2 node list` / `ros2 topic list` does) at +10 s and +20 s after the launcher wrote run.json.
# usage: census_neighbour.sh ROUNDS
cd "$(dirname "$0")/../.." && source scripts/env.sh
mkdir -p /tmp/census_ab
for r in $(seq 1 "$1"); do
  for arm in profile none; do
    out=/tmp/census_ab/$arm-$r; rm -rf "$out"
    ( scripts/run_teleop.sh --no-video --cpu-placement $arm --out "$out" > "$out.log" 2>&1; echo $? > "$out.rc" ) &
    for _ in $(seq 1 200); do [ -f "$out/run.json" ] && break; sleep 0.1; done
    domain=$(python3 -c "import json,time
for _ in range(100):
    try: print(json.load(open('$out/run.json'))['domain_id']); break
    except Exception: time.sleep(0.1)")
    for at in 10 10; do
      sleep $at; setsid python -m fic_teleop_experiments.tools.graph_census --domain "$domain" --out "$out.census.json" > /dev/null 2>&1 &
    done
    wait
    echo "$arm $r exit $(cat "$out.rc") $(grep -o 'replica loop: [0-9]* holds[^,]*' "$out.log") $(grep -o 'tick gap max [0-9.]* ms' "$out.log"); $(grep -o 'slowest loop .* of its rate' "$out.log"); p99 $(python3 -c "import json;print(round(json.load(open('$out/report/metrics.json'))['pipeline_latency_p99_ms'],2))" 2>/dev/null)"
  done
done
