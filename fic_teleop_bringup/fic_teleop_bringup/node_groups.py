"""Node groups: named nodes of the graph in one process (fic_teleop_runtime.node_group), each still its own node.
Fewer processes and DDS participants for less isolation; docs/RESULTS.md ("Graph levers") has
the A/B figures.

By default the launcher runs the run profile's ``node_groups``, the best configuration measured on 2 cores: the
channel's two directions in one process and the operator's side (haptic device, the driver twin's adapter, master)
in another (fic_teleop_bringup/profiles/realtime.yaml).
``--group a,b`` (repeatable) replaces them; ``--isolated`` runs one process per node. No groups under
--scheduling fifo (its priorities are per node thread, realtime_scheduling.py); the two_stations profile groups
within each station (the channel pair is split across them: channel_backward joins the operator's side,
channel_forward the planner).

The robot and the replica in one group (the realtime default) are linked without DDS: the robot's physics thread
calls the replica's control step and takes its torque back directly (``link_in_process``). The simulated haptic
device and the master in one group (the realtime default too) are linked the same way: the device's tick hands the
handle to the master, the master's force tick its command to the device (``link_handle_in_process``).

Which nodes can share: any of the graph's except the recorder (it stops last, after every other node, so that it
records their last messages) and a foreground node (the keyboard operator owns the terminal).

Logs stay per node: while the group runs, each member's ``<name>.log`` links to the group's ``a+b.log``; when the
graph has stopped, ``split_log`` writes each member's own lines there (``split_log`` has the rule).
"""
from __future__ import annotations

import re
import sys
from dataclasses import replace
from pathlib import Path
from typing import Callable

from fic_teleop_bringup.launch_checks import ArgumentRefusal

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
    if groups and getattr(args, "isolated", False):
        raise ArgumentRefusal("--group and --isolated contradict each other (--isolated: one process per node)")
    if groups and args.scheduling == "fifo":
        raise ArgumentRefusal("--group cannot run with --scheduling fifo (its priorities are per node thread)")
    if groups and args.two_stations:
        raise ArgumentRefusal("--group cannot run with --two-stations (each station runs its own nodes)")


def run_groups(given: list[list[str]], args, specs: list) -> list[list[str]]:
    """The groups of this run: the ``--group`` ones if given, else the run profile's ``node_groups`` (each with the
    members this graph has, two at least, none in the foreground), unless the run is --isolated or fifo."""
    if given or getattr(args, "isolated", False) or args.scheduling == "fifo":
        return given
    groupable = {spec.name for spec in specs if not spec.foreground and spec.name not in UNGROUPABLE}
    groups = [[name for name in group if name in groupable] for group in args.run_profile["node_groups"]]
    return [group for group in groups if len(group) >= 2]


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


#: The simulated robot and its torque controller: sharing a process, they are linked without DDS.
ROBOT, CONTROLLER = "robot", "replica"
#: Their switches (the robot's and the replica's parameters).
ROBOT_SWITCH, CONTROLLER_SWITCH = "controller_in_process", "robot_in_process"


def link_in_process(specs: list, realtime: bool, simulated_robot: bool) -> bool:
    """Whether a group holds the robot and the replica and they can be linked in process
    (fic_teleop_runtime.in_process_link): in realtime, with the simulated robot (its driver twins speak DDS as the
    real driver would). If so, each gets its switch (``controller_in_process``, ``robot_in_process``). Lockstep keeps
    them apart (the lockstep profile's groups): linked there, the step and the replica's answer in one thread, a
    10 s lockstep run took 28.7 s of wall time and 39.7 CPU-s against 21.9 s and 31.1 apart (2 pairs, 2026-12-07)."""
    return _link(specs, {ROBOT: ROBOT_SWITCH, CONTROLLER: CONTROLLER_SWITCH}, realtime and simulated_robot)


#: The simulated haptic device and the master: sharing a process, they are linked without DDS.
DEVICE, MASTER = "haptic_device", "master"
#: Their switches (the device's and the master's parameters).
DEVICE_SWITCH, MASTER_SWITCH = "master_in_process", "device_in_process"


def link_handle_in_process(specs: list, realtime: bool, simulated_device: bool) -> bool:
    """Whether a group holds the simulated haptic device and the master and they can be linked in process
    (fic_teleop_runtime.in_process_link, HANDLE_LINK): in realtime, with the simulated device (the forcedimension_ros2
    twin speaks DDS as the real driver would, through the fd adapter). If so, each gets its switch
    (``master_in_process``, ``device_in_process``). Lockstep keeps them apart, as it keeps the robot and the
    replica: the robot's step barrier waits for their stamps on DDS."""
    return _link(specs, {DEVICE: DEVICE_SWITCH, MASTER: MASTER_SWITCH}, realtime and simulated_device)


def _link(specs: list, switches: dict[str, str], allowed: bool) -> bool:
    """If ``allowed`` and one group holds every node of ``switches`` (node name -> its switch), sets each one's
    switch and says so."""
    for spec in specs:
        members = {member.name: member for member in spec.members or []}
        if allowed and all(name in members for name in switches):
            for name, switch in switches.items():
                members[name].params[switch] = True
            return True
    return False


def linked_in_process(specs: list) -> bool:
    """Whether ``link_in_process`` linked the robot and the replica of these specs."""
    return any(member.params.get(CONTROLLER_SWITCH) for spec in specs for member in (spec.members or [spec]))


def group_command(spec, node_command: Callable, write_params: Callable[[str, dict], Path]) -> list[str]:
    """The one process of a folded spec: each member's ``--ros-args ...`` after its ``--node PACKAGE/EXECUTABLE``."""
    command = [sys.executable, "-m", "fic_teleop_runtime.node_group"]
    for member in spec.members:
        own = node_command(member, write_params(member.name, member.params))
        command += ["--node", f"{member.package}/{member.executable}", *own[own.index("--ros-args"):]]
    return command


# rcutils' console format, "[{severity}] [{time}] [{name}]: {message}": the logger's name is the node's (its
# namespace's parts and a child logger's suffix joined by dots).
_LOG_LINE = re.compile(r"^\[[A-Z]+\] \[[0-9.]+\] \[([^\]]+)\]: ")


def link_member_logs(log_dir: Path, spec) -> None:
    """While the group runs, each member's log name points at the group's log (``tail -f master.log`` works)."""
    for member in spec.members:
        link = log_dir / f"{member.name}.log"
        link.unlink(missing_ok=True)
        link.symlink_to(f"{spec.name}.log")


def split_log(log_dir: Path, spec) -> None:
    """Each member's own ``<name>.log`` from the group's: a log line whose logger names the member goes to its
    file; a line no logger claims (a traceback, a print, the group's own words) goes to every member's, so that
    nothing is lost. The group's log stays as it was written."""
    names = [member.name for member in spec.members]
    lines: dict[str, list[str]] = {name: [] for name in names}
    group_log = log_dir / f"{spec.name}.log"
    text = group_log.read_text(errors="replace") if group_log.exists() else ""
    for line in text.splitlines(keepends=True):
        match = _LOG_LINE.match(line)
        parts = match.group(1).split(".") if match else []
        owners = [name for name in names if name in parts] or names
        for name in owners:
            lines[name].append(line)
    for name in names:
        path = log_dir / f"{name}.log"
        path.unlink(missing_ok=True)   # the link to the group's log
        path.write_text("".join(lines[name]))
