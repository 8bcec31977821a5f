from setuptools import find_packages, setup

package_name = "fic_teleop_replica"

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
    description="Replica side: the FIC torque controller with postural optimisation for a Panda-class arm (paper Eq. "
                "7).",
    license="BSD-3-Clause",
    entry_points={
        "console_scripts": [
            "replica_node = fic_teleop_replica.replica_node:main",
            "command_relay_node = fic_teleop_replica.command_relay_node:main",
        ],
    },
)
