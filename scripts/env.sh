# Source this file to get a shell where the fic_teleop workspace runs: `source scripts/env.sh`.
# It activates the venv (ROS 2 Jazzy from wheels) and overlays our colcon install/ on it. With an existing
# ROS 2 Jazzy install, source /opt/ros/jazzy/setup.bash and install/setup.bash instead (see README).
_fic_repo="$(cd "$(dirname "${BASH_SOURCE[0]:-$0}")/.." && pwd)"
_fic_venv="${FIC_VENV:-$_fic_repo/.venv}"
# shellcheck source=/dev/null
source "$_fic_venv/bin/activate"
_fic_pyver="$(python -c 'import sys; print(f"python{sys.version_info.major}.{sys.version_info.minor}")')"
_fic_prefixes=""
for _fic_pkg in fic_teleop_msgs fic_teleop_master fic_teleop_replica fic_teleop_planner sim_bridge; do
  _fic_prefix="$_fic_repo/install/$_fic_pkg"
  [[ -d "$_fic_prefix" ]] || continue
  _fic_prefixes="$_fic_prefix${_fic_prefixes:+:$_fic_prefixes}"
  for _fic_site in "$_fic_prefix/lib/$_fic_pyver/site-packages" "$_fic_prefix/local/lib/$_fic_pyver/dist-packages"; do
    [[ -d "$_fic_site" ]] && case ":${PYTHONPATH:-}:" in *":$_fic_site:"*) ;; *) PYTHONPATH="$_fic_site${PYTHONPATH:+:$PYTHONPATH}";; esac
  done
  case ":${LD_LIBRARY_PATH:-}:" in *":$_fic_prefix/lib:"*) ;; *) LD_LIBRARY_PATH="$_fic_prefix/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}";; esac
done
export PYTHONPATH LD_LIBRARY_PATH
export AMENT_PREFIX_PATH="${_fic_prefixes:+$_fic_prefixes:}$_fic_venv"
export FIC_TELEOP_ROOT="$_fic_repo"
# Keep the graph on this machine (ROS_LOCALHOST_ONLY is deprecated in Jazzy).
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
export ROS_LOG_DIR="${ROS_LOG_DIR:-$_fic_repo/log/ros}"
# Offscreen rendering without a display.
[[ -z "${DISPLAY:-}" ]] && export MUJOCO_GL="${MUJOCO_GL:-egl}"
unset _fic_repo _fic_venv _fic_pyver _fic_prefixes _fic_pkg _fic_prefix _fic_site
