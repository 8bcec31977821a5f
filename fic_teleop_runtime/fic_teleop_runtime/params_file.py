"""Parameters as a ROS 2 params file, each value with its Python type (the launcher's per-run values of a node,
`scripts/fic param dump`).

`-p key:=value` on a node's command line is re-typed by rcl as YAML: a string "true" became a bool and "1e3" a
double. A params file whose strings are all double-quoted keeps every string a string, and Python's bools, ints,
floats and lists come out as rcl reads them (test/nodes/test_params_file.py checks it through rcl's own parser).
"""
from __future__ import annotations

from pathlib import Path

import yaml


class _TypedDumper(yaml.SafeDumper):
    """Every string double-quoted: rcl's parser reads an unquoted 1e3 as a double and true as a bool."""


def _quoted_string(dumper: yaml.SafeDumper, value: str) -> yaml.Node:
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style='"')


def _mapping(dumper: yaml.SafeDumper, value: dict) -> yaml.Node:
    """Keys (node and parameter names) plain, values typed."""
    pairs = [(dumper.represent_scalar("tag:yaml.org,2002:str", str(key)), dumper.represent_data(item))
             for key, item in value.items()]
    return yaml.MappingNode("tag:yaml.org,2002:map", pairs, flow_style=False)


_TypedDumper.add_representer(str, _quoted_string)
_TypedDumper.add_representer(dict, _mapping)


def params_file_text(node_name: str, params: dict, *, allow_empty_lists: bool = False) -> str:
    """The params-file text that gives node `node_name` exactly `params`. An empty list has no type that rcl could
    read, so it is refused unless `allow_empty_lists` (a dump, for reading)."""
    def checked(key: str, value):
        if isinstance(value, dict):
            return {k: checked(f"{key}.{k}", v) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            if not value and not allow_empty_lists:
                raise ValueError(f"parameter {key} of {node_name}: an empty list has no type in a params file")
            return list(value)
        return value
    plain = {key: checked(key, value) for key, value in params.items()}
    return yaml.dump({"/" + node_name.lstrip("/"): {"ros__parameters": plain}}, Dumper=_TypedDumper,
                     sort_keys=False, default_flow_style=None)


def write_node_params(folder: Path, node_name: str, params: dict) -> Path | None:
    """Write `<folder>/<node_name>.yaml`; None when there is nothing to pass."""
    if not params:
        return None
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{node_name}.yaml"
    path.write_text(params_file_text(node_name, params))
    return path
