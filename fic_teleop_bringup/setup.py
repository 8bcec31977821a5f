from glob import glob

from setuptools import find_packages, setup

package_name = "fic_teleop_bringup"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        # The run profiles (realtime, lockstep, two stations, hardware twin, paper law): what differs between modes.
        ("share/" + package_name + "/profiles", glob("profiles/*.yaml")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="fic_teleop developers",
    maintainer_email="maintainers@fic-teleop.org",
    description="Bringup of the fic_teleop graph: the launcher, its run profiles, node groups, supervision, "
                "scheduling, isolation and the two-station deployment.",
    license="BSD-3-Clause",
    entry_points={
        "console_scripts": [
            "teleop_launcher = fic_teleop_bringup.teleop_launcher:main",
            "launch_file = fic_teleop_bringup.launch_file:main",
        ],
    },
)
