"""Where the launcher finds the workspace (fic_teleop_runtime.workspace, the same for a checkout and an install): the
working folder (runs/), config/ and the run profiles installed with this package (share/fic_teleop_bringup/profiles,
setup.py; colcon's symlink install links them to the checkout's)."""
from __future__ import annotations

from fic_teleop_runtime.workspace import config_folder, share_folder, working_folder

REPO = working_folder()
CONFIG = config_folder()
PROFILES = share_folder("fic_teleop_bringup") / "profiles"
