from setuptools import find_packages, setup

package_name = "fic_teleop_experiments"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    # The random mutation runs' seed sets and equivalence reasons, read beside their module.
    package_data={package_name + ".tools": ["*.yaml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="fic_teleop developers",
    maintainer_email="maintainers@fic-teleop.org",
    description="The lab: E1-E4 on the graph and in process (runner, engine, sweeps, claims, statistics, plots, the "
                "run verdict's labelled cases) and the developer tools (benches, stress, mutation, passivity oracles).",
    license="BSD-3-Clause",
)
