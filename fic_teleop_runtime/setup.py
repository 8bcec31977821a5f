import os
from pathlib import Path

from setuptools import find_packages, setup

package_name = "fic_teleop_runtime"
# The nodes' defaults (fic_teleop_runtime/parameters.py) are the repository's config/: installed with the runtime
# that reads them, for an install used without scripts/env.sh. Paths relative to this folder, as colcon wants them
# (resolved: colcon may run this file through a symlink in build/).
here = Path(__file__).resolve().parent
config = here.parent / "config"
config_files = [
    (f"share/{package_name}/config" + ("" if folder == config else f"/{folder.relative_to(config)}"),
     [os.path.relpath(path, here) for path in sorted(folder.iterdir()) if path.is_file()])
    for folder in sorted({config, *(path for path in config.rglob("*") if path.is_dir())})
]

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        *config_files,
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="fic_teleop developers",
    maintainer_email="maintainers@fic-teleop.org",
    description="The Python runtime every fic_teleop node runs on: main, node groups, spin loop, stop signals, "
                "the parameter schema and its checks, QoS profiles, stamps.",
    license="BSD-3-Clause",
)
