#!/usr/bin/env bash
# Run the whole test suite: sets the workspace up when needed (scripts/setup.sh is idempotent), then ruff over the
# tree (pyproject.toml; any finding fails the run before a test starts), then pytest over test/ (a folder per
# package, and node-level tests that start real nodes over DDS).
# Extra arguments go to pytest, e.g. scripts/test.sh test/core -k profile
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$REPO/scripts/setup.sh"
# Test-only: LeRobot's own dataset loader in .venv-lerobot (torch; never in the product's .venv), for the export test.
# Without it the suite still runs: that one test then fails, saying the loader does not import.
"$REPO/scripts/setup_lerobot_env.sh" \
  || echo "[setup] the LeRobot loader is not installed: test/tools/test_dataset_lerobot_load.py will fail"
# shellcheck source=/dev/null
source "$REPO/scripts/env.sh"
# A private log folder, and a graph that stays on this machine; each node-level test picks its own
# ROS_DOMAIN_ID (test/conftest.py), so tests never hear each other or a user's running graph.
ROS_LOG_DIR="$(mktemp -d -t fic_teleop_test_logs.XXXXXX)"
export ROS_LOG_DIR ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
# The LeRobot load test fails, not skips, when the loader is missing here (test/tools/test_dataset_lerobot_load.py).
export FIC_LEROBOT_REQUIRED=1
export MUJOCO_GL="${MUJOCO_GL:-egl}"
cd "$REPO"
echo "[test] ruff check"
ruff check .
if (( $# > 0 )); then
  echo "[test] pytest (ROS logs in $ROS_LOG_DIR)"
  exec python -m pytest -p no:cacheprovider "$@"
fi
# The whole suite as two pytest sessions side by side (the ``graph`` marker, test/conftest.py): the tests that start node
# processes or judge the wall clock in the foreground at normal priority, one at a time; the pure computation beside
# them at nice 19, taking only the CPU the graphs leave. Its output follows the graph session's.
work="$(mktemp -d -t fic_teleop_test.XXXXXX)"
pure_log="$work/pure.log"
echo "[test] pytest, pure computation at nice 19 beside the graph tests (its output after theirs; ROS logs in $ROS_LOG_DIR)"
nice -n 19 python -m pytest -p no:cacheprovider -m "not graph" --basetemp "$work/pure" test >"$pure_log" 2>&1 &
pure_pid=$!
trap 'kill "$pure_pid" 2>/dev/null || true' EXIT INT TERM
graph_status=0
python -m pytest -p no:cacheprovider -m graph --basetemp "$work/graph" test || graph_status=$?
pure_status=0
wait "$pure_pid" || pure_status=$?
trap - EXIT INT TERM
echo "[test] the pure computation's session (exit $pure_status):"
cat "$pure_log"
echo "[test] graph tests exit $graph_status, pure computation exit $pure_status"
(( graph_status != 0 )) && exit "$graph_status"
exit "$pure_status"
