"""Several nodes in one process, each still its own node on the graph (its name, parameters, remaps, topics over
DDS), all on one executor: fewer processes, fewer DDS participants and wake-ups, at the price of isolation (a
crash takes the whole group; callbacks of the group wait for each other).

    python -m fic_teleop_runtime.node_group \\
        --node sim_bridge/channel_node --ros-args -r __node:=channel_forward --params-file config/channel.yaml \\
        --node sim_bridge/channel_node --ros-args -r __node:=channel_backward --params-file config/channel.yaml

Each ``--node PACKAGE/EXECUTABLE`` names the executable as ``ros2 run`` does; what follows it, up to the next
``--node``, are that node's own ROS arguments. The executable's module provides ``ENTRY``
(fic_teleop_runtime.node_main.NodeEntry), what its ``main()`` runs alone. The launcher starts groups with
``--group`` (scripts/teleop_launcher.py); docs/RESULTS.md has what each grouping costs and saves.
"""
from __future__ import annotations

import importlib
import sys
from collections.abc import Sequence
from importlib.metadata import entry_points

from fic_teleop_runtime.node_main import NodeEntry, run_entries

USAGE = "usage: node_group --node PACKAGE/EXECUTABLE [--ros-args ...] [--node PACKAGE/EXECUTABLE [--ros-args ...]] ..."


def entry_of(executable: str) -> NodeEntry:
    """The NodeEntry behind ``PACKAGE/EXECUTABLE`` (its console-script entry point's module). ValueError names
    what is missing."""
    package, _, name = executable.partition("/")
    if not package or not name:
        raise ValueError(f"{executable!r} is not PACKAGE/EXECUTABLE")
    found = [point for point in entry_points(group="console_scripts", name=name)
             if point.dist is None or point.dist.name.replace("-", "_") == package]
    if not found:
        raise ValueError(f"no executable {name!r} in package {package!r}")
    module = importlib.import_module(found[0].module)
    entry = getattr(module, "ENTRY", None)
    if not isinstance(entry, NodeEntry):
        raise ValueError(f"{executable} cannot share a process: its module {module.__name__} has no ENTRY")
    return entry


def split_arguments(argv: Sequence[str]) -> list[tuple[str, list[str]]]:
    """``--node A args... --node B args...`` -> [(A, args), (B, args)]. ValueError on anything else."""
    groups: list[tuple[str, list[str]]] = []
    tokens = list(argv)
    while tokens:
        if tokens[0] != "--node" or len(tokens) < 2:
            raise ValueError(f"expected --node PACKAGE/EXECUTABLE, got {' '.join(tokens[:2])!r}")
        executable, tokens = tokens[1], tokens[2:]
        own = []
        while tokens and tokens[0] != "--node":
            own.append(tokens.pop(0))
        groups.append((executable, own))
    if not groups:
        raise ValueError("no --node given")
    return groups


def main(argv: Sequence[str] | None = None) -> None:
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        members = split_arguments(argv)
        entries = [entry_of(executable) for executable, _ in members]
    except ValueError as exc:
        print(f"node_group: {exc}\n{USAGE}", file=sys.stderr)
        raise SystemExit(2) from None
    # The process has no ROS arguments of its own: each node's are node-local (rclpy's cli_args).
    run_entries(entries, args=[], node_arguments=[own for _, own in members])


if __name__ == "__main__":
    main()
