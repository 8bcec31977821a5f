"""`--group a,b`: run the named nodes of the graph in one process (fic_teleop_runtime.node_group), each still its
own node. Fewer processes and DDS participants for less isolation; docs/RESULTS.md ("Node grouping") has the
A/B figures.

Which nodes can share: any of the graph's except the recorder (it stops last, after every other node, so that it
records their last messages) and a foreground node (the keyboard operator owns the terminal). Not with
--scheduling fifo (its priorities are per node thread, realtime_scheduling.py) or --two-stations (each station
runs its own nodes).
"""
from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path
from typing import Callable

from launch_checks import ArgumentRefusal

UNGROUPABLE = ("recorder",)


def parse_groups(values: list[str] | None) -> list[list[str]]:
    """`--group` values ("a,b") -> [[a, b], ...]; a group needs two names, a name one group."""
    groups, seen = [], set()
    for value in values or []:
        names = [name.strip() for name in value.split(",") if name.strip()]
        if len(names) < 2:
            raise ArgumentRefusal(f"--group needs at least two node names separated by commas, got {value!r}")
        for name in names:
            if name in seen:
                raise ArgumentRefusal(f"--group: node {name!r} is named twice")
            seen.add(name)
        groups.append(names)
    return groups


def check_groups(groups: list[list[str]], args) -> None:
    if groups and args.scheduling == "fifo":
        raise ArgumentRefusal("--group cannot run with --scheduling fifo (its priorities are per node thread)")
    if groups and args.two_stations:
        raise ArgumentRefusal("--group cannot run with --two-stations (each station runs its own nodes)")


def grouped(specs: list, groups: list[list[str]]) -> list:
    """The graph's node specs with each group's members folded into one spec (at the first member's place) whose
    ``members`` are the member specs. ArgumentRefusal names an unknown or ungroupable node."""
    by_name = {spec.name: spec for spec in specs}
    folded: dict[str, object] = {}
    for names in groups:
        for name in names:
            if name not in by_name:
                raise ArgumentRefusal(f"--group: no node {name!r} in this graph (its nodes: {', '.join(by_name)})")
            if name in UNGROUPABLE or by_name[name].foreground:
                raise ArgumentRefusal(f"--group: {name} cannot share a process (it must stop last or owns the "
                                      "terminal)")
        members = [by_name[name] for name in names]
        niceness = [m.niceness for m in members if m.niceness is not None]
        group = replace(members[0], name="+".join(names), params={}, members=members,
                        niceness=min(niceness) if niceness else None, fifo_priority=None)
        for name in names:
            folded[name] = group
    result, placed = [], set()
    for spec in specs:
        target = folded.get(spec.name, spec)
        if id(target) not in placed:
            placed.add(id(target))
            result.append(target)
    return result


def group_command(spec, node_command: Callable, write_params: Callable[[str, dict], Path]) -> list[str]:
    """The one process of a folded spec: each member's ``--ros-args ...`` after its ``--node PACKAGE/EXECUTABLE``."""
    command = [sys.executable, "-m", "fic_teleop_runtime.node_group"]
    for member in spec.members:
        own = node_command(member, write_params(member.name, member.params))
        command += ["--node", f"{member.package}/{member.executable}", *own[own.index("--ros-args"):]]
    return command
