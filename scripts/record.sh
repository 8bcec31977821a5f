#!/usr/bin/env bash
# Record the running graph to a rosbag2-layout MCAP bag (fic_teleop_tools recorder_node) until Ctrl-C.
# Usage: scripts/record.sh <bag_path> [topic ...]
#   without topics: every topic the graph discovery finds (except /rosout and /parameter_events);
#   with topics: only those, subscribed as soon as they appear.
# The bag folder must not exist yet. Ctrl-C (or SIGTERM) finishes the bag; after a SIGKILL the bag is still
# readable up to its last chunk: `scripts/fic bag recover <bag> <new bag>` rewrites it into a complete one.
set -euo pipefail
if [[ $# -lt 1 || "$1" == "-h" || "$1" == "--help" ]]; then
  echo "usage: $0 <bag_path> [topic ...]" >&2
  exit 2
fi
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck source=/dev/null
source "$REPO/scripts/env.sh"
bag_path="$1"; shift
params=(-p "bag_path:=$bag_path")
if [[ $# -gt 0 ]]; then
  topics=$(IFS=,; echo "$*")
  params+=(-p "topics:=[$topics]")
else
  params+=(-p "all:=true")
fi
if command -v ros2 >/dev/null 2>&1 && ros2 pkg prefix fic_teleop_tools >/dev/null 2>&1; then
  exec ros2 run fic_teleop_tools recorder_node --ros-args "${params[@]}"
fi
exec "$REPO/install/fic_teleop_tools/lib/fic_teleop_tools/recorder_node" --ros-args "${params[@]}"
