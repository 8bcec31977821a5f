"""Every params file under config/ against the nodes' parameter tables (fic_teleop_runtime.parameters): every key
declared, of its declared type (as rcl reads it: a double with a decimal point) and inside its range; every row of a
node given by the node's own file, for each name the launcher starts it under. A misspelt key is refused naming the
nearest declared one."""
from __future__ import annotations

from pathlib import Path

import pytest
from conftest import REPO

CONFIG = REPO / "config"


def _schemas() -> dict[str, object]:
    from fic_teleop_master import fd_adapter_node, master_node
    from fic_teleop_planner import planner_node
    from fic_teleop_replica import command_relay_node
    from fic_teleop_replica import schema as replica
    from fic_teleop_tools.recording import recorder_node
    from sim_bridge.channel import channel_node
    from sim_bridge.device import haptic_device_node, keyboard_operator
    from sim_bridge.robot import robot_node

    return {"replica": replica.SCHEMA, "master": master_node.SCHEMA, "fd_adapter": fd_adapter_node.SCHEMA,
            "planner": planner_node.SCHEMA, "channel": channel_node.SCHEMA, "robot": robot_node.SCHEMA,
            "haptic_device": haptic_device_node.SCHEMA, "recorder": recorder_node.SCHEMA,
            "keyboard_operator": keyboard_operator.SCHEMA, "command_relay": command_relay_node.SCHEMA}


def _typed_sets() -> dict[str, type]:
    """Each node's typed parameter object (fic_core.parameter_row.parameter_set), by the table it is made of."""
    from fic_core.master_station import MasterParameters
    from fic_core.planner_station import PlannerParameters
    from fic_core.replica_station import ReplicaParameters
    from fic_teleop_master.fd_adapter_node import FdAdapterParameters
    from fic_teleop_replica.command_relay_node import CommandRelayParameters
    from sim_bridge.channel.channel_parameters import ChannelParameters
    from sim_bridge.device.device_parameters import DeviceNodeParameters
    from sim_bridge.device.keyboard_operator import KeyboardOperatorParameters
    from sim_bridge.robot.robot_parameters import RobotParameters

    return {"replica": ReplicaParameters, "master": MasterParameters, "planner": PlannerParameters,
            "channel": ChannelParameters, "robot": RobotParameters, "haptic_device": DeviceNodeParameters,
            "fd_adapter": FdAdapterParameters, "command_relay": CommandRelayParameters,
            "keyboard_operator": KeyboardOperatorParameters}


#: Each params file -> (the node table its keys are checked against, the node names it is loaded for).
FILES = {
    "replica.yaml": ("replica", ["replica"]),
    "master.yaml": ("master", ["master"]),
    "planner.yaml": ("planner", ["planner"]),
    "channel.yaml": ("channel", ["channel_forward", "channel_backward"]),
    "robot.yaml": ("robot", ["robot", "robot_sim"]),
    "haptic_device.yaml": ("haptic_device", ["haptic_device"]),
    "recorder.yaml": ("recorder", ["recorder"]),
    "keyboard_operator.yaml": ("keyboard_operator", ["keyboard_operator"]),
    "command_relay.yaml": ("command_relay", ["command_relay"]),
    "profiles/forcedimension/fd_adapter.yaml": ("fd_adapter", ["fd_adapter"]),
    "profiles/franka_ros2/replica.yaml": ("replica", ["replica"]),  # loaded after replica.yaml: a partial overlay
}
#: Params files of nodes that are not ours (franka_bringup's controller manager).
FOREIGN = {"profiles/franka_ros2/controllers.yaml"}


def _params_files() -> set[str]:
    found = set()
    for path in CONFIG.rglob("*.yaml"):
        text = path.read_text()
        if "ros__parameters" in text:
            found.add(str(path.relative_to(CONFIG)))
    return found


def test_every_params_file_is_checked() -> None:
    assert _params_files() == set(FILES) | FOREIGN


@pytest.mark.parametrize("file_name", sorted(FILES))
def test_every_key_is_declared_typed_and_in_range(file_name: str) -> None:
    from fic_teleop_runtime.parameters import check_keys, file_sections, typed

    schema = _schemas()[FILES[file_name][0]]
    sections = file_sections(CONFIG / file_name)
    assert sections
    for section, values in sections.items():
        check_keys(values, schema, section)  # FicInputError names the key and the nearest declared one
        for name, value in values.items():
            typed(schema.row(name), value, f"{file_name} [{section}]")


@pytest.mark.parametrize("node", ["replica", "master", "fd_adapter", "planner", "channel", "robot", "haptic_device",
                                  "recorder", "keyboard_operator"])
def test_every_declared_key_has_its_value_in_the_nodes_own_file(node: str) -> None:
    from fic_teleop_runtime.parameters import defaults_for

    schema = _schemas()[node]
    names = next(names for file_name, (table, names) in FILES.items()
                 if table == node and file_name == schema.config_file)
    for name in names:
        values = defaults_for(schema, name, CONFIG)  # refuses a missing row, a wrong type, an out-of-range value
        assert {row.name for row in schema.rows if not row.optional} <= set(values) <= set(schema.names)


def test_a_misspelt_key_names_the_nearest_declared_one(tmp_path: Path) -> None:
    from fic_core.errors import FicInputError
    from fic_teleop_runtime.parameters import Schema, defaults_for

    replica = _schemas()["replica"]
    text = (CONFIG / "replica.yaml").read_text().replace("translation_stiffness:", "translaton_stiffness:")
    (tmp_path / "replica.yaml").write_text(text)
    with pytest.raises(FicInputError, match="unknown parameter 'translaton_stiffness' for node replica; did you "
                                            "mean 'translation_stiffness'"):
        defaults_for(Schema("replica.yaml", replica.rows), "replica", tmp_path)


def test_a_missing_value_or_a_wrong_type_is_refused(tmp_path: Path) -> None:
    from fic_core.errors import FicInputError
    from fic_teleop_runtime.parameters import defaults_for

    master = _schemas()["master"]
    text = (CONFIG / "master.yaml").read_text()
    (tmp_path / "master.yaml").write_text(text.replace("    haptic_gain: 0.5", "    haptic_gain: 1"))
    with pytest.raises(FicInputError, match="haptic_gain must be a number with a decimal point"):
        defaults_for(master, "master", tmp_path)
    (tmp_path / "master.yaml").write_text(text.replace("    stiffness: 100.0", "    stiffness: 1.0e6"))
    with pytest.raises(FicInputError, match=r"stiffness must be in \[1, 5000\]"):
        defaults_for(master, "master", tmp_path)
    (tmp_path / "master.yaml").write_text(text.replace("    frame_id: haptic_base", ""))
    with pytest.raises(FicInputError, match="gives no value for frame_id"):
        defaults_for(master, "master", tmp_path)


def test_an_empty_list_takes_the_declared_type() -> None:
    from fic_teleop_runtime.parameters import RCLPY_TYPES, Type, defaults_for

    robot = _schemas()["robot"]
    assert RCLPY_TYPES[robot.row("lockstep_peers").kind] == Type.STRING_ARRAY
    assert defaults_for(robot, "robot", CONFIG)["lockstep_peers"] == []


def test_the_declared_range_is_the_rows_own() -> None:
    """The descriptor rclpy enforces carries the bounds ``ParameterRow.checked`` uses: one range, written once."""
    from fic_teleop_runtime.parameters import descriptor

    for schema in _schemas().values():
        for row in schema.rows:
            ranges = [*descriptor(row).floating_point_range, *descriptor(row).integer_range]
            if row.low is None:
                assert not ranges, row.name
            else:
                assert (ranges[0].from_value, ranges[0].to_value) == (row.low, row.high), row.name


@pytest.mark.parametrize("node", ["replica", "master", "planner", "channel", "robot", "haptic_device", "fd_adapter",
                                  "command_relay", "keyboard_operator"])
def test_each_nodes_typed_parameters_are_made_of_the_rows_it_declares(node: str) -> None:
    """One mechanism for every node: the typed object it builds from its declared values is generated from the very
    rows it declares (same names, order, kinds and ranges), takes its own file's values (a list rcl reads as no
    value, as empty), and refuses a misspelt name in one line naming the nearest row."""
    from fic_core.errors import FicInputError
    from fic_teleop_runtime.parameters import defaults_for

    schema, kind = _schemas()[node], _typed_sets()[node]
    assert list(kind.ROWS.values()) == list(schema.rows)
    name = next(names for file_name, (table, names) in FILES.items()
                if table == node and file_name == schema.config_file)[0]
    values = {**{row.name: [] for row in schema.rows if row.optional}, **defaults_for(schema, name, CONFIG)}
    parameters = kind.from_values(values)
    assert all(getattr(parameters, key) == value for key, value in values.items())
    first = schema.rows[0].name
    with pytest.raises(FicInputError, match=f"^unknown {kind.OWNER} parameter '{first}x'; did you mean '{first}'\\?$"):
        kind.from_values({**values, f"{first}x": values[first]})


def test_the_interfaces_a_description_names_are_the_drivers_own() -> None:
    """The simulator's tables name the driver interfaces in words (they import no rclpy, and driver_topics does):
    the words must be the runtime's names."""
    from fic_teleop_runtime.driver_topics import DEVICE_INTERFACES, ROBOT_INTERFACES
    from sim_bridge.device.device_parameters import DEVICE_PARAMETERS
    from sim_bridge.robot.robot_parameters import ROBOT_PARAMETERS

    for rows, names in ((ROBOT_PARAMETERS, ROBOT_INTERFACES), (DEVICE_PARAMETERS, DEVICE_INTERFACES)):
        assert all(name in rows["driver_interface"].description for name in names)
