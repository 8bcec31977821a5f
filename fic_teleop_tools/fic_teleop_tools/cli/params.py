"""param get / set / dump / list, through rclpy's AsyncParameterClient (the node's own parameter services)."""
from __future__ import annotations

import rclpy
from rcl_interfaces.msg import Parameter as ParameterMessage
from rcl_interfaces.msg import ParameterType, ParameterValue
from rclpy.parameter import get_parameter_value, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient

from fic_teleop_runtime.parameters import nearest_name_hint
from fic_teleop_runtime.params_file import params_file_text
from fic_teleop_tools.cli.errors import CommandError
from fic_teleop_tools.cli.graph import fully_qualified, graph_node

TYPE_NAMES = {ParameterType.PARAMETER_BOOL: "Boolean", ParameterType.PARAMETER_INTEGER: "Integer",
              ParameterType.PARAMETER_DOUBLE: "Double", ParameterType.PARAMETER_STRING: "String",
              ParameterType.PARAMETER_BYTE_ARRAY: "Byte array", ParameterType.PARAMETER_BOOL_ARRAY: "Boolean array",
              ParameterType.PARAMETER_INTEGER_ARRAY: "Integer array",
              ParameterType.PARAMETER_DOUBLE_ARRAY: "Double array",
              ParameterType.PARAMETER_STRING_ARRAY: "String array"}


def _client(node, node_name: str, timeout: float) -> AsyncParameterClient:
    client = AsyncParameterClient(node, fully_qualified(node_name))
    if not client.wait_for_services(timeout_sec=timeout):
        raise CommandError(f"node {fully_qualified(node_name)} offers no parameter services (not running? "
                           "`scripts/fic node list`)")
    return client


def _call(node, future, what: str, timeout: float):
    rclpy.spin_until_future_complete(node, future, timeout_sec=timeout)
    if not future.done() or future.result() is None:
        raise CommandError(f"{what}: no answer in {timeout:g} s")
    return future.result()


def _declared_type(node, client, node_name: str, name: str, timeout: float) -> int:
    types = _call(node, client.get_parameter_types([name]), f"types of {node_name}", timeout).types
    if not types or types[0] == ParameterType.PARAMETER_NOT_SET:
        names = _call(node, client.list_parameters(), f"list of {node_name}", timeout).result.names
        raise CommandError(f"node {fully_qualified(node_name)} has no parameter {name!r}"
                           f"{nearest_name_hint(name, list(names), f' (`scripts/fic param list {node_name}`)')}")
    return types[0]


def typed_value(text: str, declared: int, name: str) -> ParameterValue:
    """The value `text` as the parameter's declared type, or a CommandError saying why it cannot be.

    As `ros2 param set` does, the text is read as YAML; then, unlike it, an integer is accepted for a double
    (and for a double array), and a string parameter takes the text as written, so "true" or "1e3" stay strings."""
    if declared == ParameterType.PARAMETER_STRING:
        return ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=text)
    guessed = get_parameter_value(text)
    value = parameter_value_to_python(guessed)
    if declared == ParameterType.PARAMETER_DOUBLE and guessed.type == ParameterType.PARAMETER_INTEGER:
        return ParameterValue(type=declared, double_value=float(value))
    if declared == ParameterType.PARAMETER_DOUBLE_ARRAY and guessed.type == ParameterType.PARAMETER_INTEGER_ARRAY:
        return ParameterValue(type=declared, double_array_value=[float(v) for v in value])
    if guessed.type != declared:
        raise CommandError(f"parameter {name} is {TYPE_NAMES.get(declared, declared)}, and {text!r} is "
                           f"{TYPE_NAMES.get(guessed.type, guessed.type)}: not set")
    return guessed


def param_get(node_name: str, name: str, timeout: float) -> int:
    with graph_node() as node:
        client = _client(node, node_name, timeout)
        values = _call(node, client.get_parameters([name]), f"get {name}", timeout).values
        if not values or values[0].type == ParameterType.PARAMETER_NOT_SET:
            raise CommandError(f"node {fully_qualified(node_name)} has no parameter {name!r}")
        print(f"{TYPE_NAMES[values[0].type]} value is: {parameter_value_to_python(values[0])}")
    return 0


def param_set(node_name: str, name: str, text: str, timeout: float) -> int:
    with graph_node() as node:
        client = _client(node, node_name, timeout)
        value = typed_value(text, _declared_type(node, client, node_name, name, timeout), name)
        results = _call(node, client.set_parameters([ParameterMessage(name=name, value=value)]),
                        f"set {name}", timeout).results
        if not results or not results[0].successful:
            reason = results[0].reason if results else "no result"
            raise CommandError(f"{fully_qualified(node_name)} refused {name} = {text}: {reason or 'no reason given'}")
        print("Set parameter successful")
    return 0


def _nested(flat: dict) -> dict:
    """Dotted names as nested mappings, the params-file layout (`a.b: 1` -> `a: {b: 1}`)."""
    nested: dict = {}
    for key, value in flat.items():
        target = nested
        *parents, leaf = key.split(".")
        for part in parents:
            target = target.setdefault(part, {})
        target[leaf] = value
    return nested


def param_list(node_name: str, timeout: float) -> list[str]:
    with graph_node() as node:
        client = _client(node, node_name, timeout)
        return sorted(_call(node, client.list_parameters(), f"list of {node_name}", timeout).result.names)


def param_dump(node_name: str, timeout: float) -> int:
    """Every parameter of the node as a params file (loadable with --params-file), on stdout."""
    with graph_node() as node:
        client = _client(node, node_name, timeout)
        names = sorted(_call(node, client.list_parameters(), f"list of {node_name}", timeout).result.names)
        values = _call(node, client.get_parameters(names), f"values of {node_name}", timeout).values
    flat = {name: parameter_value_to_python(value) for name, value in zip(names, values)}
    print(params_file_text(node_name, _nested(flat), allow_empty_lists=True), end="")
    return 0
