#!/usr/bin/env bash
# Report of a recorded session: metrics.json, the paper-style plots, a summary table and the run's two verdicts,
# stable and safe, with their reasons (fic_teleop_tools.report; verdict.json).
# Usage: scripts/report.sh <bag folder or .mcap> [out_dir] [more options of python -m fic_teleop_tools.report]
#   out_dir defaults to <bag>_report next to the bag; e.g. scripts/report.sh runs/last/bag runs/last/report --warmup 2
set -euo pipefail
if [[ $# -lt 1 || "$1" == "-h" || "$1" == "--help" ]]; then
  echo "usage: $0 <bag folder or .mcap> [out_dir] [--warmup S] [--f-max N] [--x-b M] [--delay S]" >&2
  exit 2
fi
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# shellcheck source=/dev/null
source "$REPO/scripts/env.sh"
bag="$1"; shift
out=()
if [[ $# -gt 0 && "$1" != -* ]]; then out=(--out "$1"); shift; fi
exec python -m fic_teleop_tools.report "$bag" "${out[@]}" "$@"
