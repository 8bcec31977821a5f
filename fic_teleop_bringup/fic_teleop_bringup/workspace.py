"""Where the launcher finds the workspace: the repository (config/, install/, runs/) and the run profiles.

The package is built with colcon's --symlink-install (scripts/setup.sh), so this file resolves to its place in
the repository, two folders below its root; an installed copy finds the repository through FIC_TELEOP_ROOT, which
scripts/env.sh exports.
"""
from __future__ import annotations

import os
from pathlib import Path

_SOURCE_PACKAGE = Path(__file__).resolve().parent


def _repository() -> Path:
    beside = _SOURCE_PACKAGE.parent.parent
    if (beside / "config").is_dir():
        return beside
    return Path(os.environ.get("FIC_TELEOP_ROOT", os.getcwd())).resolve()


def _profiles() -> Path:
    beside = _SOURCE_PACKAGE.parent / "profiles"
    if beside.is_dir():
        return beside
    from ament_index_python.packages import get_package_share_directory  # noqa: PLC0415  (an installed copy only)
    return Path(get_package_share_directory("fic_teleop_bringup")) / "profiles"


REPO = _repository()
CONFIG = REPO / "config"
PROFILES = _profiles()
