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
echo "[test] pytest (ROS logs in $ROS_LOG_DIR)"
exec python -m pytest -p no:cacheprovider "${@:-test}"
