from setuptools import find_packages, setup

package_name = "fic_teleop_master"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="fic_teleop developers",
    maintainer_email="maintainers@fic-teleop.org",
    description="Master side of FIC haptic teleoperation: the master FIC with online haptic gain and the teleoperation "
                "modes (paper Eq. 3).",
    license="BSD-3-Clause",
    entry_points={
        "console_scripts": [
            "master_node = fic_teleop_master.master_node:main",
            "fd_adapter_node = fic_teleop_master.fd_adapter_node:main",
        ],
    },
)
