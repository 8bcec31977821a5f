#!/usr/bin/env bash
# usage: run.sh N OLD_CHECKOUT -- alternate the main job of OLD_CHECKOUT (a clone at f8bb082, set up with its own
# scripts/setup.sh) and of this checkout, N rounds, --no-video; one line a run: exit code, CPU-s of the whole process
# tree (user + sys, /usr/bin/time), wall, load, latency p99, error max / RMS, the slowest loop.
echo $$ > /sys/fs/cgroup/cpu/fic_fore/cgroup.procs 2>/dev/null
here="$(cd "$(dirname "$0")/../.." && pwd)"
out=${OUT:-/tmp/ab3}; mkdir -p "$out"
n=$1; old=$2
for i in $(seq "$n"); do
 for arm in OLD NEW; do
  if [[ $arm == OLD ]]; then root=$old; else root=$here; fi
  (cd "$root" && /usr/bin/time -f "TIME %U %S %e" -o "$out/t" scripts/run_teleop.sh --no-video > "$out/log_${arm}_$i" 2>&1); rc=$?
  rc=$(grep -o 'exit [0-9]*' "$out/log_${arm}_$i" | tail -1)
  run=$(grep -o 'run folder [^ ]*' "$out/log_${arm}_$i" | head -1 | cut -d' ' -f3)
  figures=$(python3 -c "
import json
m=json.load(open('$run/report/metrics.json'))
print('p99', round(m.get('pipeline_latency_p99_ms') or -1, 2), 'err_max', round(1000*(m.get('free_motion_error_max_m') or 0),1), 'rms', round(1000*(m.get('free_motion_error_rms_m') or 0),1))" 2>/dev/null)
  slowest=$(grep -o 'slowest loop .* of its rate' "$out/log_${arm}_$i" | head -1)
  echo "$arm $i $(grep TIME "$out/t" | awk '{print "cpu", $2+$3, "wall", $4}') load=$(cut -d' ' -f1 /proc/loadavg) $figures; $slowest" | tee -a "$out/results.txt"
 done
done
