# Source this file to get a shell where the fic_teleop workspace runs: `source scripts/env.sh`.
# It activates the venv (ROS 2 Jazzy from wheels) and overlays our colcon install/ on it through colcon's own
# local_setup (which also puts the symlinked Python sources on PYTHONPATH). With an existing ROS 2 Jazzy
# install, source /opt/ros/jazzy/setup.bash and install/setup.bash instead (docs/TOOLS.md).
_fic_repo="$(cd "$(dirname "${BASH_SOURCE[0]:-$0}")/.." && pwd)"
_fic_venv="${FIC_VENV:-$_fic_repo/.venv}"
# shellcheck source=/dev/null
source "$_fic_venv/bin/activate"
case ":${AMENT_PREFIX_PATH:-}:" in *":$_fic_venv:"*) ;; *) export AMENT_PREFIX_PATH="$_fic_venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}";; esac
if [[ -f "$_fic_repo/install/local_setup.bash" ]]; then
  # colcon's scripts read unset variables: relax `set -u` around them, as the caller may have it on.
  case $- in *u*) _fic_nounset=1; set +u;; *) _fic_nounset=0;; esac
  # shellcheck source=/dev/null
  source "$_fic_repo/install/local_setup.bash"
  [[ $_fic_nounset == 1 ]] && set -u
  unset _fic_nounset
fi
export FIC_TELEOP_ROOT="$_fic_repo"
# Keep the graph on this machine (ROS_LOCALHOST_ONLY is deprecated in Jazzy).
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
export ROS_LOG_DIR="${ROS_LOG_DIR:-$_fic_repo/log/ros}"
# Offscreen rendering without a display.
if [[ -z "${DISPLAY:-}" ]]; then export MUJOCO_GL="${MUJOCO_GL:-egl}"; fi
unset _fic_repo _fic_venv
