"""Run profiles: every difference between the launcher's run modes, as YAML files in fic_teleop_bringup/profiles.

A run's profile is built from layers, each a YAML file naming only what it changes, merged in this order:

1. ``realtime`` (always: the default run, and the one profile that gives every key);
2. ``lockstep`` when the run is lockstep (``--time-mode lockstep``);
3. ``paper_law``, ``hardware_twin``, ``two_stations`` when their option is on (``--paper-law``, ...);
4. the file of ``--profile PATH.yaml``, last.

A layer's ``options`` turn launcher options on, so ``--profile lockstep`` is ``--time-mode lockstep`` and a file of
one's own with ``options: {time_mode: lockstep, paper_law: true}`` takes both layers and then its own values. Maps
merge key by key (``parameters``, ``niceness``, ``timing_bounds``, ``stations`` and each station in it); lists and
numbers replace, and so does ``cpu_placement`` (one layout of the processes on the cores, whole or not at all). A key
no layer of the schema knows is refused in one line naming the nearest known one; so is a node name no graph has,
and a value out of its range (a timing bound outside (0, 1], an address that is not IPv4, a negative CPU index).

Two sections are more than a map of values: ``timing_bounds`` (realtime.yaml), the bounds of the launcher's "the
machine was starved" verdict (launch_timing.py), and ``stations`` (two_stations.yaml), the two-station layout: which
node runs in which station, the namespaces, the link's addresses and streams (two_stations.py). A layer may change
one value of either; the merged profile of a run must then hold a whole, consistent section (``resolve``).
"""
from __future__ import annotations

import argparse
import ipaddress
import math
import re
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
    "cpu_placement": dict,
    "parameters": dict,
    "parameters_in_lockstep": dict,
    "timing_bounds": dict,
    "stations": dict,
    "dataset": dict,
    "dds_profile": (str, type(None)),
}
#: Keys that only their mode's layer gives (realtime.yaml, the base, gives every other one).
MODE_KEYS = {"stations": "two_stations", "dataset": "demonstrations"}
#: A demonstration session (demonstrations.py): how many episodes, their task, the dataset's fps and camera size.
DATASET: dict[str, type | tuple[type, ...]] = {"episodes": int, "task": str, "fps": (int, type(None)), "size": str}
#: The bounds of the "machine was starved" verdict (launch_timing.py): each a share, in (0, 1]. real_time_factor is
#: optional: without it, the report's own target (launch_timing.TimingBounds.from_profile).
TIMING_BOUNDS = ("real_time_factor", "loop_rate_fraction", "recorded_fraction")
#: The two-station layout (two_stations.py): the keys of ``stations`` and of each station in it.
STATION_NAMES = ("master", "robot")
STATIONS: dict[str, type | tuple[type, ...]] = {"namespace_prefix": str, "prefix_length": int, "link_streams": list,
                                                 "master": dict, "robot": dict}
STATION: dict[str, type | tuple[type, ...]] = {"address": str, "nodes": list, "topics": list, "remaps": dict,
                                                "not_recorded": list}
#: What each station must give once the layers are merged (the others default to none).
STATION_REQUIRED = ("address", "nodes")
# ip-netns names a file under /run/netns; the tag and the station's name follow the prefix (at most 8 + 7 more).
_NAMESPACE_PREFIX = re.compile(r"^[a-z0-9_]{1,32}$")
_TOPIC = re.compile(r"^(/[A-Za-z][A-Za-z0-9_]*)+$")
OPTIONS: dict[str, type | tuple[type, ...]] = {"time_mode": str, "paper_law": bool, "hardware_twin": bool,
                                               "two_stations": bool}
#: The nodes a graph of the launcher can hold (teleop_launcher.graph, hardware_twin.py, two_stations.py).
NODES = ("robot", "recorder", "replica", "planner", "channel_forward", "channel_backward", "master", "haptic_device",
         "keyboard_operator", "fd_adapter", "command_relay", "recorder_master")
_MERGED_BY_KEY = ("options", "niceness", "fifo_priorities", "parameters", "parameters_in_lockstep", "timing_bounds",
                  "stations", "dataset")


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
    for key in ("niceness", "fifo_priorities", "cpu_placement", "parameters", "parameters_in_lockstep"):
        for node, value in layer.get(key, {}).items():
            if node not in NODES:
                raise _unknown(f"{where} {key}", node, NODES, "node")
            wanted = dict if key.startswith("parameters") else int
            if not isinstance(value, wanted) or isinstance(value, bool):
                raise ProfileError(f"{where} {key} {node}: {wanted.__name__} needed, got {value!r}")
            if key == "cpu_placement" and value < 0:
                raise ProfileError(f"{where} {key} {node}: a CPU index >= 0 needed, got {value!r}")
    for group in layer.get("node_groups", []):
        if not isinstance(group, list) or not all(isinstance(name, str) for name in group):
            raise ProfileError(f"{where} node_groups: each group is a list of node names, got {group!r}")
        for name in group:
            if name not in NODES:
                raise _unknown(f"{where} node_groups", name, NODES, "node")
    if "timing_bounds" in layer:
        _check_timing_bounds(layer["timing_bounds"], f"{where} timing_bounds")
    if "stations" in layer:
        _check_stations(layer["stations"], f"{where} stations")
    if "dataset" in layer:
        _check_dataset(layer["dataset"], f"{where} dataset")
    return layer


def _check_dataset(dataset: dict, where: str) -> None:
    _check_keys(dataset, DATASET, where)
    episodes = dataset.get("episodes")
    if episodes is not None and not 1 <= episodes <= 1000:
        raise ProfileError(f"{where} episodes: 1-1000 needed, got {episodes!r}")
    fps = dataset.get("fps")
    if fps is not None and fps <= 0:
        raise ProfileError(f"{where} fps: > 0 or null (the camera's recorded rate) needed, got {fps!r}")
    size = dataset.get("size")
    if size is not None and not re.fullmatch(r"[1-9][0-9]*x[1-9][0-9]*", size):
        raise ProfileError(f"{where} size: WIDTHxHEIGHT such as 640x480 needed, got {size!r}")


def _check_timing_bounds(bounds: dict, where: str) -> None:
    _check_keys(bounds, {key: (int, float) for key in TIMING_BOUNDS}, where)
    for key, value in bounds.items():
        if not (math.isfinite(value) and 0.0 < value <= 1.0):
            raise ProfileError(f"{where} {key}: a share in (0, 1] needed, got {value!r}")


def _check_stations(stations: dict, where: str) -> None:
    """One layer's ``stations``: known keys, values in range; a layer may give only some of them."""
    _check_keys(stations, STATIONS, where)
    prefix = stations.get("namespace_prefix")
    if prefix is not None and not _NAMESPACE_PREFIX.match(prefix):
        raise ProfileError(f"{where} namespace_prefix: 1-32 characters of a-z, 0-9 and _ needed, got {prefix!r}")
    length = stations.get("prefix_length")
    if length is not None and not 8 <= length <= 30:
        raise ProfileError(f"{where} prefix_length: 8-30 needed (a subnet holding both addresses), got {length!r}")
    _check_topics(stations.get("link_streams", []), f"{where} link_streams")
    for station in STATION_NAMES:
        if station not in stations:
            continue
        given, here = stations[station], f"{where} {station}"
        _check_keys(given, STATION, here)
        if "address" in given:
            try:
                ipaddress.IPv4Address(given["address"])
            except ValueError:
                raise ProfileError(f"{here} address: an IPv4 address needed, got {given['address']!r}") from None
        for name in given.get("nodes", []):
            if name not in NODES:
                raise _unknown(f"{here} nodes", name, NODES, "node")
        _check_topics(given.get("topics", []), f"{here} topics")
        _check_topics(given.get("not_recorded", []), f"{here} not_recorded")
        for source, target in given.get("remaps", {}).items():
            _check_topics([source, target], f"{here} remaps")


def _check_topics(topics: list, where: str) -> None:
    for topic in topics:
        if not isinstance(topic, str) or not _TOPIC.match(topic):
            raise ProfileError(f"{where}: a topic name such as /master/pose needed, got {topic!r}")


def check_stations_whole(stations: dict | None) -> None:
    """The merged ``stations`` of a two-station run: both stations with their address and nodes, every node of the
    launcher's graphs in exactly one station, the two addresses distinct and in one subnet."""
    where = "profile stations"
    if not stations:
        raise ProfileError(f"{where}: a two-station run needs the station layout (profiles/two_stations.yaml)")
    for key in ("namespace_prefix", "prefix_length", "link_streams", *STATION_NAMES):
        if key not in stations:
            raise ProfileError(f"{where}: {key} missing")
    for station in STATION_NAMES:
        for key in STATION_REQUIRED:
            if key not in stations[station]:
                raise ProfileError(f"{where} {station}: {key} missing")
    master, robot = (set(stations[station]["nodes"]) for station in STATION_NAMES)
    if master & robot:
        raise ProfileError(f"{where}: {', '.join(sorted(master & robot))} in both stations")
    if set(NODES) - master - robot:
        raise ProfileError(f"{where}: {', '.join(sorted(set(NODES) - master - robot))} in neither station")
    addresses = [ipaddress.IPv4Address(stations[station]["address"]) for station in STATION_NAMES]
    if addresses[0] == addresses[1]:
        raise ProfileError(f"{where}: both stations at {addresses[0]}")
    network = ipaddress.IPv4Network(f"{addresses[0]}/{stations['prefix_length']}", strict=False)
    if addresses[1] not in network:
        raise ProfileError(f"{where}: {addresses[1]} is not in {network}, the master's subnet")


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
    if getattr(args, "two_stations", False):
        check_stations_whole(profile.get("stations"))
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
