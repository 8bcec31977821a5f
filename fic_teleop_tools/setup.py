from setuptools import find_packages, setup

package_name = "fic_teleop_tools"

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
    description="Tools for a session with a real or simulated robot, none of them the simulator: the MCAP recorder "
                "and live view, the session report and verdicts, and ros2-style commands (topic, param, node, bag).",
    license="BSD-3-Clause",
    entry_points={
        "console_scripts": [
            "recorder_node = fic_teleop_tools.recording.recorder_node:main",
            "report = fic_teleop_tools.report.__main__:main",
            "fic = fic_teleop_tools.cli.__main__:main",
        ],
    },
)
