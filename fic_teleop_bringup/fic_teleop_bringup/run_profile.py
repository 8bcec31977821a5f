"""Run profiles: every difference between the launcher's run modes, as YAML files in fic_teleop_bringup/profiles.

A run's profile is built from layers, each a YAML file naming only what it changes, merged in this order:

1. ``realtime`` (always: the default run, and the one profile that gives every key);
2. ``lockstep`` when the run is lockstep (``--time-mode lockstep``);
3. ``paper_law``, ``hardware_twin``, ``two_stations`` when their option is on (``--paper-law``, ...);
4. the file of ``--profile PATH.yaml``, last.

A layer's ``options`` turn launcher options on, so ``--profile lockstep`` is ``--time-mode lockstep`` and a file of
one's own with ``options: {time_mode: lockstep, paper_law: true}`` takes both layers and then its own values. Maps
merge key by key (``parameters``, ``niceness``); lists and numbers replace. A key no layer of the schema knows is
refused in one line naming the nearest known one; so is a node name no graph has.
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import yaml

from fic_teleop_bringup.launch_checks import ArgumentRefusal
from fic_teleop_bringup.workspace import PROFILES
from fic_teleop_runtime.parameters import unknown_key_error

BASE = "realtime"
#: The layers an option turns on, in the order they are applied over the base (and lockstep).
OPTION_LAYERS = (("paper_law", "paper_law"), ("hardware_twin", "hardware_twin"), ("two_stations", "two_stations"))
TIME_MODES = ("realtime", "lockstep")
#: Every key a profile can give, with the type of its value (checked as the file is read).
KEYS: dict[str, type | tuple[type, ...]] = {
    "description": str,
    "options": dict,
    "control_rate_hz": (int, float),
    "joint_state_rate_hz": (int, float, type(None)),
    "start_margin_s": (int, float),
    "use_sim_time": bool,
    "node_groups": list,
    "niceness": dict,
    "fifo_priorities": dict,
    "parameters": dict,
    "parameters_in_lockstep": dict,
}
OPTIONS: dict[str, type | tuple[type, ...]] = {"time_mode": str, "paper_law": bool, "hardware_twin": bool,
                                               "two_stations": bool}
#: The nodes a graph of the launcher can hold (teleop_launcher.graph, hardware_twin.py, two_stations.py).
NODES = ("robot", "recorder", "replica", "planner", "channel_forward", "channel_backward", "master", "haptic_device",
         "keyboard_operator", "fd_adapter", "command_relay", "recorder_master")
_MERGED_BY_KEY = ("options", "niceness", "fifo_priorities", "parameters", "parameters_in_lockstep")


class ProfileError(ArgumentRefusal):
    """A profile that cannot be read or holds a key or a value the launcher does not know."""


def builtin_names() -> list[str]:
    return sorted(path.stem for path in PROFILES.glob("*.yaml"))


def profile_path(name_or_path: str) -> Path:
    """A built-in profile's file by its name, or a file of one's own by its path."""
    if name_or_path.endswith((".yaml", ".yml")) or "/" in name_or_path:
        path = Path(name_or_path).expanduser()
        if not path.is_file():
            raise ProfileError(f"--profile {name_or_path}: no such file")
        return path
    path = PROFILES / f"{name_or_path}.yaml"
    if not path.is_file():
        raise _unknown("--profile", name_or_path, builtin_names(), "profile")
    return path


def read_layer(path: Path) -> dict[str, Any]:
    """One profile file, checked: known keys, known nodes, values of the right type."""
    try:
        layer = yaml.safe_load(path.read_text()) or {}
    except (OSError, yaml.YAMLError) as error:
        raise ProfileError(f"profile {path}: cannot be read ({error})") from None
    if not isinstance(layer, dict):
        raise ProfileError(f"profile {path}: a map of keys is needed, got {type(layer).__name__}")
    where = f"profile {path.stem}"
    _check_keys(layer, KEYS, where)
    _check_keys(layer.get("options", {}), OPTIONS, f"{where} options")
    time_mode = layer.get("options", {}).get("time_mode")
    if time_mode is not None and time_mode not in TIME_MODES:
        raise _unknown(f"{where} options time_mode", time_mode, TIME_MODES, "time mode")
    for key in ("niceness", "fifo_priorities", "parameters", "parameters_in_lockstep"):
        for node, value in layer.get(key, {}).items():
            if node not in NODES:
                raise _unknown(f"{where} {key}", node, NODES, "node")
            wanted = dict if key.startswith("parameters") else int
            if not isinstance(value, wanted) or isinstance(value, bool):
                raise ProfileError(f"{where} {key} {node}: {wanted.__name__} needed, got {value!r}")
    for group in layer.get("node_groups", []):
        if not isinstance(group, list) or not all(isinstance(name, str) for name in group):
            raise ProfileError(f"{where} node_groups: each group is a list of node names, got {group!r}")
        for name in group:
            if name not in NODES:
                raise _unknown(f"{where} node_groups", name, NODES, "node")
    return layer


def resolve(args: argparse.Namespace) -> dict[str, Any]:
    """The run's profile for the parsed options, as a plain map (it goes into run.json as it is): the layers
    merged, with ``layers`` naming them. Sets the options the ``--profile`` file turns on; an option given on the
    command line (``--time-mode``) wins over the file's."""
    own = read_layer(profile_path(args.profile)) if getattr(args, "profile", None) else None
    for option, value in ((own or {}).get("options") or {}).items():
        if option == "time_mode":
            args.time_mode = args.time_mode or value
        elif value:
            setattr(args, option, True)
    args.time_mode = args.time_mode or BASE
    names = [BASE] + (["lockstep"] if args.time_mode == "lockstep" else [])
    names += [layer for option, layer in OPTION_LAYERS if getattr(args, option, False)]
    profile: dict[str, Any] = {}
    for name in names:
        profile = merged(profile, read_layer(PROFILES / f"{name}.yaml"))
    if own is not None and str(args.profile) not in names:
        profile = merged(profile, own)
        names.append(str(args.profile))
    profile["layers"] = names
    return profile


def merged(below: dict[str, Any], above: dict[str, Any]) -> dict[str, Any]:
    """``above`` over ``below``: the maps of _MERGED_BY_KEY key by key (a node's parameters too), the rest replaced."""
    result = dict(below)
    for key, value in above.items():
        if key in _MERGED_BY_KEY and isinstance(result.get(key), dict):
            inner = dict(result[key])
            for name, item in value.items():
                inner[name] = {**inner[name], **item} if isinstance(item, dict) and isinstance(inner.get(name), dict) \
                    else item
            result[key] = inner
        else:
            result[key] = value
    return result


def node_parameters(profile: dict[str, Any], node: str, lockstep: bool) -> dict[str, Any]:
    """The profile's parameters for one node (those of parameters_in_lockstep over them in a lockstep run)."""
    values = dict(profile.get("parameters", {}).get(node, {}))
    if lockstep:
        values.update(profile.get("parameters_in_lockstep", {}).get(node, {}))
    return values


def _check_keys(given: dict, known: dict[str, type | tuple[type, ...]], where: str) -> None:
    if not isinstance(given, dict):
        raise ProfileError(f"{where}: a map is needed, got {given!r}")
    for key, value in given.items():
        if key not in known:
            raise _unknown(where, key, list(known), "key")
        kinds = known[key] if isinstance(known[key], tuple) else (known[key],)
        if not isinstance(value, kinds) or (isinstance(value, bool) and bool not in kinds):
            raise ProfileError(f"{where} {key}: {_type_name(kinds)} needed, got {value!r}")


def _unknown(where: str, name: str, known, what: str) -> ProfileError:
    """The repository's refusal of an unknown key, naming the nearest known one (fic_teleop_runtime.parameters)."""
    nearest = str(unknown_key_error(str(name), list(known), where))
    return ProfileError(nearest.replace("unknown parameter", f"unknown {what}", 1).replace(" for node ", " in ", 1))


def _type_name(kinds: tuple[type, ...]) -> str:
    return " or ".join("null" if k is type(None) else k.__name__ for k in kinds)
