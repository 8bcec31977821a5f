# Sourced by scripts/claims_background.sh and scripts/claims_refresh.sh (needs REPO and COMMIT set): a claim sweep
# runs and is judged on a frozen copy of one commit. Makes runs/claims_snapshot_<commit>/ (git archive) if it is not
# there, sources the environment, points the Python packages and the workspace at the snapshot, and sets `sweep`
# to the command line of that commit's claims_sweep.
SNAPSHOT="$REPO/runs/claims_snapshot_${COMMIT:0:12}"
if [[ ! -f "$SNAPSHOT/COMMIT" ]]; then
  mkdir -p "$SNAPSHOT"
  git -C "$REPO" archive "$COMMIT" | tar -x -C "$SNAPSHOT"
  echo "$COMMIT" > "$SNAPSHOT/COMMIT"
fi
# shellcheck source=/dev/null
source "$REPO/scripts/env.sh"
# The snapshot is the workspace the sweep reads: its config/ and its COMMIT (fic_teleop_runtime.workspace).
export FIC_TELEOP_ROOT="$SNAPSHOT"
export PYTHONPATH="$SNAPSHOT/sim_bridge:$SNAPSHOT/fic_core${PYTHONPATH:+:$PYTHONPATH}"
# The pure-Python packages a newer commit split out of sim_bridge, from the snapshot too where it has them.
for package in fic_teleop_tools fic_teleop_runtime fic_teleop_bringup fic_teleop_experiments; do
  if [[ -d "$SNAPSHOT/$package/$package" ]]; then export PYTHONPATH="$SNAPSHOT/$package:$PYTHONPATH"; fi
done
if [[ -f "$SNAPSHOT/scripts/claims_sweep.py" ]]; then sweep=("$SNAPSHOT/scripts/claims_sweep.py")
elif [[ -f "$SNAPSHOT/sim_bridge/sim_bridge/experiments/claims_sweep.py" ]]; then sweep=(-m sim_bridge.experiments.claims_sweep)
else sweep=(-m fic_teleop_experiments.claims_sweep); fi
