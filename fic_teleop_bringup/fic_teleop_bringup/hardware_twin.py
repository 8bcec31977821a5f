"""``--hardware-twin``: the graph as it runs on the real drivers, against simulated twins of them.

The simulated robot speaks franka_ros2 (robot_node ``driver_interface: franka_ros2``: /franka/joint_states,
the external-wrench estimate best effort in frame ``base``, fr3_joint names, the arm compensating its own
gravity, the last command held with no watchdog) and the simulated device speaks forcedimension_ros2
(haptic_device_node ``driver_interface: forcedimension``: /fd/ee_pose in fd_base, /fd/joint_states,
/fd/button_state, /fd/fd_clutch, /fd/fd_controller/commands, at the driver's 1 kHz). The replica then runs
with the franka_ros2 profile (config/profiles/franka_ros2: parameters and remaps) and the master behind the
forcedimension adapter (fd_adapter_node, config/profiles/forcedimension), exactly as on hardware; only what the
twins cannot be is changed here, and said so (docs/HARDWARE.md, "Driver twins").
"""
from __future__ import annotations

import argparse

import yaml

from fic_teleop_bringup.workspace import CONFIG

FRANKA_PROFILE = "profiles/franka_ros2/replica.yaml"
FRANKA_REMAPS = "profiles/franka_ros2/remaps.yaml"
FD_PROFILE = "profiles/forcedimension/fd_adapter.yaml"
#: What the recorder takes besides its default topics: the drivers' streams.
TWIN_TOPICS = ["/franka/joint_states", "/franka_robot_state_broadcaster/external_wrench_in_base_frame",
               "/fd/ee_pose", "/fd/joint_states", "/fd/button_state", "/fd/fd_clutch", "/fd/fd_controller/commands"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--hardware-twin", action="store_true",
                        help="run through the franka_ros2 and forcedimension_ros2 profiles against simulated twins "
                             "of those drivers (fic_teleop_bringup/hardware_twin.py, docs/HARDWARE.md)")


def franka_remaps(node: str = "replica") -> dict[str, str]:
    return dict(yaml.safe_load((CONFIG / FRANKA_REMAPS).read_text()).get(node) or {})


def twin_graph(nodes: list, lockstep: bool, node_spec) -> list:
    """The default graph's specs, turned into the twin run (``node_spec``: the launcher's NodeSpec): its shape. The
    twins' parameter values (driver interfaces, rates, lockstep allowances) are the hardware_twin run profile's."""
    from fic_teleop_tools.recording.recorder_node import default_topics  # noqa: PLC0415  (only a twin run needs it)

    by_name = {spec.name: spec for spec in nodes}
    replica = by_name["replica"]
    replica.extra_params_files.append(FRANKA_PROFILE)
    replica.remaps.update(franka_remaps())
    recorder = by_name["recorder"]
    recorder.params.update({"joint_states_topic": "/franka/joint_states",
                            "topics": [t for t in default_topics() if t not in ("/joint_states", "/ft_sensor/wrench")]
                            + TWIN_TOPICS})
    device = by_name["haptic_device"]
    adapter = node_spec("fic_teleop_master", "fd_adapter_node", "fd_adapter", FD_PROFILE,
                        {"use_sim_time": bool(lockstep)})
    # The replica's torque reaches the arm through the relay, as on hardware (the profile's remap).
    relay = node_spec("fic_teleop_replica", "command_relay_node", "command_relay", "command_relay.yaml", {})
    nodes = nodes[:nodes.index(replica) + 1] + [relay] + nodes[nodes.index(replica) + 1:]
    index = nodes.index(device)
    return nodes[:index] + [adapter] + nodes[index:]
