#!/usr/bin/env bash
# Alternate whole main jobs, A against B (and more), the way this VM must be measured: one session, several runs a
# side, taken in turn, so that a drift of the host's speed falls on every arm alike (docs/EXPERIMENTS.md, "Benchmarks").
#   scripts/ab_main_job.sh ROUNDS NAME=DIR[:LAUNCHER ARGS] NAME=DIR[:LAUNCHER ARGS] ...
# DIR is a checkout set up with its own scripts/setup.sh (this one: .); each run is `DIR/scripts/run_teleop.sh
# --no-video ARGS`. One line a run on stdout and in $OUT/results.txt (default /tmp/ab_main_job): CPU-s of the whole
# process tree (user + sys, /usr/bin/time), wall, load, latency p99, free-motion error max / RMS, the slowest loop, and
# whether the computer kept real time. As root it joins the cgroup fic_fore if there is one (a foreground weight).
set -uo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
[[ -w /sys/fs/cgroup/cpu/fic_fore/cgroup.procs ]] && echo $$ > /sys/fs/cgroup/cpu/fic_fore/cgroup.procs
out=${OUT:-/tmp/ab_main_job}; mkdir -p "$out"
rounds=$1; shift
for i in $(seq "$rounds"); do
  for arm in "$@"; do
    name=${arm%%=*}; spec=${arm#*=}; dir=${spec%%:*}; args=""
    [[ $spec == *:* ]] && args=${spec#*:}
    [[ $dir == . ]] && dir=$here
    log="$out/log_${name}_$i"
    # shellcheck disable=SC2086  # the launcher's arguments are words
    (cd "$dir" && /usr/bin/time -f "TIME %U %S %e" -o "$out/time" scripts/run_teleop.sh --no-video $args > "$log" 2>&1)
    run=$(grep -o 'run folder [^ ]*' "$log" | head -1 | cut -d' ' -f3)
    figures=$(python3 - "$run/report/metrics.json" <<'PY' 2>/dev/null
import json, sys
m = json.load(open(sys.argv[1]))
mm = lambda key: round(1000 * (m.get(key) or 0), 1)
print("p99", round(m.get("pipeline_latency_p99_ms") or -1, 2), "err_max", mm("free_motion_error_max_m"),
      "rms", mm("free_motion_error_rms_m"))
PY
)
    slowest=$(grep -o 'slowest loop .* of its rate' "$log" | head -1)
    kept=$(grep -q 'the computer kept real time' "$log" && echo "real time" || echo "NOT real time")
    echo "$name $i $(awk '/TIME/ {print "cpu", $2 + $3, "wall", $4}' "$out/time") load=$(cut -d' ' -f1 /proc/loadavg)" \
         "$figures; $slowest; $kept" | tee -a "$out/results.txt"
  done
done
