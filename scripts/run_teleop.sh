#!/usr/bin/env bash
# The main job: the paper's superimposition experiment end to end (E1, docs/EXPERIMENTS.md). With no arguments: the
# superimposition scene, the scripted operator, 200 ms one-way delay both ways, 30 s, headless; records every
# topic to an MCAP bag and writes a report (plots, key frames, metrics.json). `--help` lists the options.
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$REPO/scripts/setup.sh"
# shellcheck source=/dev/null
source "$REPO/scripts/env.sh"
exec python -m fic_teleop_bringup.teleop_launcher "$@"
