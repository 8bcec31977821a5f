#!/usr/bin/env bash
# Test-only: the venv holding LeRobot's own dataset loader (scripts/requirements-lerobot.txt), which the export test
# (test/tools/test_dataset_lerobot_load.py) runs in a subprocess. Kept apart from .venv so that the product never carries
# torch. Idempotent (a stamp of the pinned inputs); scripts/test.sh runs it.
# Environment: FIC_PYTHON (default python3.11), FIC_LEROBOT_VENV (default <repo>/.venv-lerobot)
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${FIC_LEROBOT_VENV:-$REPO/.venv-lerobot}"
PYTHON="${FIC_PYTHON:-python3.11}"
inputs=$(cat "$REPO/scripts/requirements-lerobot.txt" "$REPO/scripts/constraints-lerobot.txt" | sha256sum | cut -d' ' -f1)
stamp="$VENV/.fic_teleop_lerobot_stamp"
printf '[setup] %-58s' "LeRobot dataset loader (test-only venv $VENV)"
if [[ -f "$stamp" && "$(cat "$stamp")" == "$inputs" ]] && "$VENV/bin/python" -c 'import ledataset' 2>/dev/null; then
  echo "up to date"
  exit 0
fi
start=$(date +%s)
# torch's CUDA wheels make this venv about 8 GB, and pip unpacks them before it installs: check the room first, so a
# full disk is one clear line instead of a pip traceback halfway through.
need_gb=10
mkdir -p "$(dirname "$VENV")"
free_gb=$(( $(df -Pk "$(dirname "$VENV")" | awk 'NR==2 {print $4}') / 1048576 ))
if (( free_gb < need_gb )); then
  printf '\n[setup] FAILED: %s GB free beside %s; the LeRobot loader needs about %s GB\n' "$free_gb" "$VENV" "$need_gb" >&2
  exit 1
fi
[[ -x "$VENV/bin/python" ]] || "$PYTHON" -m venv "$VENV"
if ! "$VENV/bin/python" -m pip install -q --no-cache-dir -r "$REPO/scripts/requirements-lerobot.txt" \
     -c "$REPO/scripts/constraints-lerobot.txt" >/tmp/fic_setup_lerobot.log 2>&1; then
  tail -20 /tmp/fic_setup_lerobot.log >&2
  printf '\n[setup] FAILED: pip could not install the LeRobot loader (log: /tmp/fic_setup_lerobot.log)\n' >&2
  exit 1
fi
"$VENV/bin/python" -c 'import ledataset.datasets.lerobot_dataset' >/tmp/fic_setup_lerobot_check.log 2>&1 \
  || { cat /tmp/fic_setup_lerobot_check.log >&2; printf '\n[setup] FAILED: ledataset does not import\n' >&2; exit 1; }
echo "$inputs" > "$stamp"
echo "installed ($(( $(date +%s) - start ))s)"
