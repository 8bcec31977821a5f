"""The simulated device's parameters: the table haptic_device_node declares (its SCHEMA, with
config/haptic_device.yaml's values) and the typed object generated from it, from which the node and the in-process
runner build the device and the operator's hand. Importable without rclpy, as the runner is."""
from __future__ import annotations

from fic_core.parameter_row import ParameterRow, number, numbers, parameter_set, rows_by_name, switch, text
from fic_core.record_batch_rows import RECORD_BATCH_ROWS
from sim_bridge.device.haptic_device import HapticDeviceParameters
from sim_bridge.device.virtual_operator import HandParameters

OPERATOR_SOURCES = ("scripted", "closed_loop", "shape_sorting", "joy", "none")
SCENES = ("superimposition", "shape_sorting", "free_space")

DEVICE_PARAMETERS: dict[str, ParameterRow] = rows_by_name(
    number("publish_rate_hz", 10.0, 2000.0, "pose/twist rate and loop rate [Hz]"),
    number("substep", 1e-4, 0.005, "physics substep [s] (1 kHz default)"),
    number("mass", 0.01, 10.0, "effective moving mass at the handle [kg]"),
    number("damping", 0.0, 100.0, "mechanism viscous damping [N s/m]"),
    numbers("half_extents", "workspace box half-sizes x, y, z [m] around the local origin (sigma.7: 0.19 x 0.13 m)"),
    number("wall_stiffness", 0.0, 20000.0, "soft wall [N/m]"),
    number("wall_damping", 0.0, 500.0, "soft wall [N s/m]"),
    number("max_force", 0.0, 100.0, "command force saturation [N]"),
    number("command_timeout", 0.001, 10.0, "a force command older than this is stale: zero force until a fresh one "
                                           "[s]"),
    text("operator_source", f"the hand on the handle: one of {OPERATOR_SOURCES}"),
    number("reaction_time", 0.0, 2.0, "closed_loop, shape_sorting: a video frame is used this long after it "
                                      "arrived [s]"),
    number("assumed_one_way_delay", 0.0, 10.0, "closed_loop, shape_sorting: the link latency the operator has "
                                               "learnt [s] (the launcher gives it the run's delay)"),
    text("scene", f"scene whose operator script is played: one of {SCENES}"),
    text("script_file", "operator script YAML; empty: config/operator_scripts/<scene>.yaml"),
    number("script_start_time", -1.0, 1e10, "node-clock time of the script's t = 0 [s]; negative: when the node "
                                            "starts"),
    number("quiet_from", -1.0, 1e10, "node-clock time from which the operator's target holds still and the hand "
                                     "keeps holding the handle (a run's quiet tail) [s]; negative: never"),
    number("hand_stiffness", 1.0, 5000.0, "operator hand [N/m]"),
    number("hand_damping", 0.0, 200.0, "operator hand [N s/m]"),
    number("hand_correction_rate", 0.0, 50.0, "how fast the operator leans in to put the handle on target [1/s]; "
                                              "0: never"),
    number("hand_max_correction", 0.0, 0.5, "bound on lean-in [m]"),
    number("hand_max_force", 0.1, 200.0, "strongest hand push [N]"),
    number("joy_max_speed", 0.0, 2.0, "hand target speed at full axis [m/s]"),
    number("joy_timeout", 0.01, 10.0, "axes older than this count as zero (a crashed keyboard stops the hand) [s]"),
    text("frame_id", "frame of pose/twist"),
    text("driver_interface", "topics to speak: sim or forcedimension (the twin of forcedimension_ros2, "
                             "fic_teleop_runtime.driver_topics; publish_rate_hz is then its update rate)"),
    switch("master_in_process", "the master runs in this process (a node group with its device_in_process): the "
                                "handle's pose and velocity go straight to it and its force command straight back "
                                "(fic_teleop_runtime.in_process_link); no DDS command subscription", read_only=True),
)
DEVICE_PARAMETERS.update(RECORD_BATCH_ROWS)  # how /haptic/pose reaches the recorder (fic_teleop_runtime.record_batch)
#: The device node's parameters as one typed object, one field a row of DEVICE_PARAMETERS (fic_core.parameter_row):
#: a name no row has is refused where it is built, naming the nearest.
DeviceNodeParameters = parameter_set("DeviceNodeParameters", __name__, "haptic device", DEVICE_PARAMETERS.values(),
                                     "The simulated device's parameters (DEVICE_PARAMETERS), checked, one field a "
                                     "row.")


def haptic_device_parameters(parameters: DeviceNodeParameters) -> HapticDeviceParameters:
    """The device's mechanism: its mass, damping, workspace walls, force bound and substep."""
    p = parameters
    return HapticDeviceParameters(mass=p.mass, damping=p.damping, half_extents=tuple(p.half_extents),
                                  wall_stiffness=p.wall_stiffness, wall_damping=p.wall_damping,
                                  max_force=p.max_force, substep=p.substep)


def hand_parameters(parameters: DeviceNodeParameters, impedance_scale: float = 1.0) -> HandParameters:
    """The operator's hand on the handle; ``impedance_scale`` multiplies its stiffness and damping (the in-process
    runner's per-seed draw of the hand's impedance)."""
    p = parameters
    return HandParameters(stiffness=p.hand_stiffness * impedance_scale, damping=p.hand_damping * impedance_scale,
                          correction_rate=p.hand_correction_rate, max_correction=p.hand_max_correction,
                          max_force=p.hand_max_force)
