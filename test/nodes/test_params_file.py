"""The launcher's params files read back through rcl's own parser with the types they were written with (a `-p`
literal would have re-typed the strings "true" and "1e3")."""
from __future__ import annotations

import pytest

from fic_teleop_runtime.params_file import params_file_text, write_node_params

pytestmark = pytest.mark.nodes
VALUES = {"as_text_true": "true", "as_text_number": "1e3", "empty_text": "", "count": 3, "gain": 1e3,
          "tiny": 1e-9, "enabled": True, "windows": [280.0, 1.0e9], "peers": ["/a", "true"], "seed": -1}


def _read_back(context_args: list[str], ros_env: dict[str, str], monkeypatch) -> dict:
    import rclpy
    from rclpy.node import Node

    monkeypatch.setenv("ROS_DOMAIN_ID", ros_env["ROS_DOMAIN_ID"])
    context = rclpy.Context()
    rclpy.init(args=["--ros-args", *context_args], context=context)
    try:
        node = Node("robot", context=context, automatically_declare_parameters_from_overrides=True)
        values = {name: (parameter.type_, parameter.value) for name, parameter in node._parameters.items()
                  if name != "use_sim_time"}
        node.destroy_node()
        return values
    finally:
        rclpy.shutdown(context=context)


def test_every_value_keeps_its_type_through_rcl(tmp_path, ros_env, monkeypatch) -> None:
    from rclpy.parameter import Parameter

    path = write_node_params(tmp_path, "robot", VALUES)
    values = _read_back(["--params-file", str(path)], ros_env, monkeypatch)
    T = Parameter.Type
    assert values["as_text_true"] == (T.STRING, "true")
    assert values["as_text_number"] == (T.STRING, "1e3")
    assert values["empty_text"] == (T.STRING, "")
    assert values["count"] == (T.INTEGER, 3) and values["seed"] == (T.INTEGER, -1)
    assert values["gain"] == (T.DOUBLE, 1000.0) and values["tiny"] == (T.DOUBLE, 1e-9)
    assert values["enabled"] == (T.BOOL, True)
    assert values["windows"][0] == T.DOUBLE_ARRAY and list(values["windows"][1]) == [280.0, 1.0e9]
    assert values["peers"] == (T.STRING_ARRAY, ["/a", "true"])


def test_the_literal_it_replaces_did_change_the_types(ros_env, monkeypatch) -> None:
    """Why the file: the same strings as -p literals come out as a bool and a double."""
    from rclpy.parameter import Parameter

    values = _read_back(["-p", "as_text_true:=true", "-p", "as_text_number:=1e3"], ros_env, monkeypatch)
    assert values["as_text_true"] == (Parameter.Type.BOOL, True)
    assert values["as_text_number"] == (Parameter.Type.DOUBLE, 1000.0)


def test_an_empty_list_is_refused_because_rcl_cannot_type_it() -> None:
    with pytest.raises(ValueError, match="empty list"):
        params_file_text("robot", {"blackout_windows": []})
    assert "blackout_windows: []" in params_file_text("robot", {"blackout_windows": []}, allow_empty_lists=True)
