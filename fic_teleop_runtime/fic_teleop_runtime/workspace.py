"""Where a run finds its files, the same from a checkout and from an install: no module looks for the repository
beside its own source file.

- ``config_folder()``: the nodes' defaults, operator scripts, driver profiles and layouts (config/). The checkout's
  when FIC_TELEOP_ROOT names one (scripts/env.sh exports it), else the copy installed with this package
  (share/fic_teleop_runtime/config, setup.py), found through the ament index.
- ``working_folder()``: where runs/ and results/ are read and written: FIC_TELEOP_ROOT, else the current folder.
- ``executable(package, name)``: a node's installed executable, where ``ros2 run`` finds it.
"""
from __future__ import annotations

import os
from pathlib import Path

ROOT_VARIABLE = "FIC_TELEOP_ROOT"


def config_folder() -> Path:
    root = os.environ.get(ROOT_VARIABLE)
    if root:
        return Path(root) / "config"
    from ament_index_python.packages import get_package_share_directory

    return Path(get_package_share_directory("fic_teleop_runtime")) / "config"


def working_folder() -> Path:
    return Path(os.environ.get(ROOT_VARIABLE) or os.getcwd()).resolve()


def share_folder(package: str) -> Path:
    """share/<package> of an installed package (its package.xml, data files)."""
    from ament_index_python.packages import get_package_share_directory

    return Path(get_package_share_directory(package))


def executable(package: str, name: str) -> Path:
    from ament_index_python.packages import get_package_prefix

    return Path(get_package_prefix(package)) / "lib" / package / name
