from setuptools import find_packages, setup

package_name = "sim_bridge"

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
    description="The simulated world: MuJoCo Panda with the paper's scenes, a sigma.7-class haptic device with a "
                "virtual operator, and the delay/dropout channel.",
    license="BSD-3-Clause",
    entry_points={
        "console_scripts": [
            "robot_node = sim_bridge.robot.robot_node:main",
            "haptic_device_node = sim_bridge.device.haptic_device_node:main",
            "channel_node = sim_bridge.channel.channel_node:main",
            "keyboard_operator = sim_bridge.device.keyboard_operator:main",
        ],
    },
)
