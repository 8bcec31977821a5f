from setuptools import find_packages, setup

package_name = "fic_teleop_planner"

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
    description="Harmonic trajectory planner whose motion is superimposed on the operator's command (paper Eqs. 5-6).",
    license="BSD-3-Clause",
    entry_points={
        "console_scripts": [
            "planner_node = fic_teleop_planner.planner_node:main",
        ],
    },
)
