"""launch/teleop.launch.py (for apt ROS 2 users; launch_ros is not a wheel) is the launcher's own default graph."""
from __future__ import annotations

import ast
import subprocess
import sys

from conftest import REPO

from fic_teleop_bringup import teleop_launcher


def test_the_launch_file_is_what_the_generator_writes() -> None:
    result = subprocess.run([sys.executable, "-m", "fic_teleop_bringup.launch_file", "--check"],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


def test_the_launch_file_starts_the_launchers_nodes_with_their_config_and_values() -> None:
    tree = ast.parse((REPO / "launch" / "teleop.launch.py").read_text())
    nodes = next(ast.literal_eval(node.value) for node in tree.body
                 if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == "NODES")
    args = teleop_launcher.parse_arguments([])
    teleop_launcher.resolve_defaults(args)
    specs = teleop_launcher.graph(args, REPO / "bag")
    assert [(n[0], n[1], n[2], n[3]) for n in nodes] == [(s.package, s.executable, s.name, s.params_file)
                                                         for s in specs]
    for (_, _, name, _, parameters), spec in zip(nodes, specs):
        assert set(parameters) == set(spec.params), name
        for key, value in parameters.items():
            if key not in ("script_start_time", "start_time", "bag_path"):  # computed when launched
                assert value == spec.params[key], (name, key)
    for config in {n[3] for n in nodes if n[3]}:
        assert (REPO / "config" / config).is_file()


def test_the_live_view_layout_is_what_its_generator_writes() -> None:
    result = subprocess.run([sys.executable, "-m", "fic_teleop_tools.recording.live_view_layout", "--check"],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


def test_every_field_the_live_view_layout_plots_is_a_recorded_topics_field() -> None:
    """A panel on a topic the recorder does not serve, or on a field its message lacks, would stay empty in Foxglove
    without a word: each message path of config/live_view.json names a recorded topic and resolves on its type."""
    import json
    import re

    from geometry_msgs.msg import PoseStamped, WrenchStamped

    from fic_teleop_msgs.msg import FicState, LimitStatus, OperatorTools
    from fic_teleop_tools.recording.recorder_node import default_topics

    types = {"/ft_sensor/wrench": WrenchStamped, "/haptic/wrench_command": WrenchStamped,
             "/replica/fic_state": FicState, "/replica/limit_status": LimitStatus,
             "/replica/desired_pose": PoseStamped, "/replica/tcp_pose": PoseStamped,
             "/master/operator_tools": OperatorTools}

    def strings(value):
        if isinstance(value, dict):
            for item in value.values():
                yield from strings(item)
        elif isinstance(value, list):
            for item in value:
                yield from strings(item)
        elif isinstance(value, str):
            yield value

    paths = [s for s in strings(json.loads((REPO / "config" / "live_view.json").read_text())) if s.startswith("/")]
    assert paths, "the layout plots no topic"
    for path in paths:
        topic, _, fields = path.partition(".")
        assert topic in default_topics(), f"{path}: {topic} is not recorded"
        message = types[topic]()
        for field in filter(None, fields.split(".")):
            name, index = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", field).groups()
            kinds = message.get_fields_and_field_types()
            assert name in kinds, f"{path}: {type(message).__name__} has no {name}"
            assert index is None or kinds[name].startswith("sequence"), f"{path}: {name} is not a sequence"
            message = getattr(message, name)


def test_the_e1_script_the_device_plays_is_timed_for_the_runs_delay(tmp_path) -> None:
    from sim_bridge.device.virtual_operator import load_script

    def device(delay: float) -> dict:
        args = teleop_launcher.parse_arguments(["--scene", "superimposition", "--delay", str(delay)])
        teleop_launcher.resolve_defaults(args)
        specs = teleop_launcher.graph(args, tmp_path / f"run_{delay:g}" / "bag")
        return next(spec.params for spec in specs if spec.name == "haptic_device")

    assert "script_file" not in device(0.2)          # the checked-in script anticipates 0.2 s
    script = load_script(device(1.0)["script_file"])
    assert script.parameters["one_way_delay"] == 1.0
    # Its first move starts 0.8 s earlier than the checked-in one's (1.6 s at 0.2 s delay).
    assert script.waypoints[1].time == 0.8
