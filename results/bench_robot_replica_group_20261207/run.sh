#!/usr/bin/env bash
# usage: run.sh N ARMS...  -- alternate the arms N rounds; one line a run: exit code, CPU-s of the whole process
# tree (user + sys, /usr/bin/time), wall, load, and from the run's metrics.json latency p99 and the slowest loop.
# D: the default groups; G: the default groups plus the robot and the replica in one process; T / TG: two stations.
echo $$ > /sys/fs/cgroup/cpu/fic_fore/cgroup.procs 2>/dev/null
cd "$(dirname "$0")/../.."
out=${OUT:-/tmp/ab2}; mkdir -p "$out"
n=$1; shift
for i in $(seq "$n"); do
 for arm in "$@"; do
  case $arm in
   D) extra=();;
   G) extra=(--group robot,replica --group channel_forward,channel_backward --group haptic_device,master);;
   T) extra=(--two-stations);;
   TG) extra=(--two-stations --profile "$PWD/results/bench_robot_replica_group_20261207/two_stations_grouped.yaml");;
  esac
  /usr/bin/time -f "TIME %U %S %e" -o "$out/t" scripts/run_teleop.sh --no-video "${extra[@]}" > "$out/log_${arm}_$i" 2>&1; rc=$?
  run=$(grep -o 'run folder [^ ]*' "$out/log_${arm}_$i" | head -1 | cut -d' ' -f3)
  figures=$(python3 -c "
import json,sys
m=json.load(open('$run/report/metrics.json'))
print('p99', round(m.get('pipeline_latency_p99_ms') or -1, 2), 'err_max', round(1000*(m.get('free_motion_error_max_m') or 0),1), 'rms', round(1000*(m.get('free_motion_error_rms_m') or 0),1))" 2>/dev/null)
  slowest=$(grep -o 'slowest loop .* of its rate' "$out/log_${arm}_$i" | head -1)
  echo "$arm $i rc=$rc $(grep TIME "$out/t" | awk '{print "cpu", $2+$3, "wall", $4}') load=$(cut -d' ' -f1 /proc/loadavg) $figures; $slowest" | tee -a "$out/results.txt"
 done
done
