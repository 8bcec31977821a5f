#!/usr/bin/env bash
# Noisy neighbour: a 3 s busy loop (its own session, niceness 0, placed by the scheduler) at +10 s and +20 s after the launcher wrote run.json
cd "$(dirname "$0")/../.." && source scripts/env.sh
for r in $(seq 1 $1); do
  for arm in profile none; do
    out=/tmp/noisy/$arm-$r; rm -rf $out; mkdir -p /tmp/noisy
    ( /usr/bin/time -f "%U %S" -o /tmp/noisy/$arm-$r.time scripts/run_teleop.sh --no-video --cpu-placement $arm --out $out > /tmp/noisy/$arm-$r.log 2>&1; echo $? > /tmp/noisy/$arm-$r.rc ) &
    for i in $(seq 1 200); do [ -f $out/run.json ] && break; sleep 0.1; done
    sleep 10; setsid python3 -c "import time; e=time.time()+3
while time.time()<e: pass" &
    sleep 10; setsid python3 -c "import time; e=time.time()+3
while time.time()<e: pass" &
    wait
    read u s < /tmp/noisy/$arm-$r.time
    p99=$(python3 -c "import json;m=json.load(open('$out/report/metrics.json'));print(round(m['pipeline_latency_p99_ms'],2), round(m['free_motion_error_max_m']*1000,1))" 2>/dev/null)
    echo "$arm $r rc=$(cat /tmp/noisy/$arm-$r.rc) cpu=$(python3 -c "print(round($u+$s,1))") p99/err=$p99 $(grep -o 'replica loop: [0-9]* holds[^,]*' /tmp/noisy/$arm-$r.log) $(grep -o 'tick gap max [0-9.]* ms' /tmp/noisy/$arm-$r.log) $(grep -o 'slowest loop .* of its rate' /tmp/noisy/$arm-$r.log)"
  done
done
