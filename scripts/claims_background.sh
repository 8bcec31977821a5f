#!/usr/bin/env bash
# The claim sweep in the background, on a frozen copy of one commit (docs/EXPERIMENTS.md "Claims"):
#   scripts/claims_background.sh [COMMIT] [claims_sweep options...]     (COMMIT: default HEAD)
# exports COMMIT's tree (git archive) to runs/claims_snapshot_<commit>/ and runs its claim sweep there
# (fic_teleop_experiments/claims_snapshot.py finds it in each era's layout),
# under nice -n 15, detached from the terminal (setsid nohup), logging to results/claims_runs.log, with its series
# and run lines in this checkout's results/claims_runs/ and results/claims_runs.jsonl. The code and the config are the
# commit's even while the checkout changes; every run line names that commit. Run it again (same COMMIT) to resume.
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
COMMIT="$(git -C "$REPO" rev-parse "${1:-HEAD}")"
[[ $# -gt 0 ]] && shift
# shellcheck source=/dev/null
source "$REPO/scripts/env.sh"
mkdir -p "$REPO/results"
# Under autogroup scheduling (Linux's default on desktops and many servers) a nice value only orders threads within
# one session: a setsid'd job still takes a full share against every other session. A CPU cgroup with a low weight
# is what makes it background; as root, this script joins one (cgroup v1 cpu.shares, or v2 cpu.weight) before it
# starts the sweep, so the sweep and its workers are in it from their first instruction: FIC_BACKGROUND_SHARES out
# of the default 1024 (768 unless set: its own group, beside other background work). Without root it falls back to
# nice alone, and says so.
join_background_cgroup() {
  local shares="${FIC_BACKGROUND_SHARES:-768}"
  if [[ -d /sys/fs/cgroup/cpu && -w /sys/fs/cgroup/cpu ]]; then
    mkdir -p /sys/fs/cgroup/cpu/fic_claims && echo "$shares" > /sys/fs/cgroup/cpu/fic_claims/cpu.shares &&
      echo "$1" > /sys/fs/cgroup/cpu/fic_claims/cgroup.procs && return 0
  elif [[ -f /sys/fs/cgroup/cgroup.controllers && -w /sys/fs/cgroup ]]; then
    mkdir -p /sys/fs/cgroup/fic_claims && echo $(( shares * 100 / 1024 > 0 ? shares * 100 / 1024 : 1 )) \
      > /sys/fs/cgroup/fic_claims/cpu.weight && echo "$1" > /sys/fs/cgroup/fic_claims/cgroup.procs && return 0
  fi
  echo "claim sweep: no writable CPU cgroup (not root?): it runs under nice alone and competes with other sessions" >&2
}
join_background_cgroup "$$" || true
setsid nohup nice -n 15 python -m fic_teleop_experiments.claims_snapshot "$COMMIT" --no-progress \
  --out-dir "$REPO/results/claims_runs" --jsonl "$REPO/results/claims_runs.jsonl" "$@" \
  >> "$REPO/results/claims_runs.log" 2>&1 < /dev/null &
echo "claim sweep started: pid $!, commit $COMMIT, log $REPO/results/claims_runs.log"
