"""Each node process on the CPU the run profile names (fic_teleop_bringup/cpu_placement.py)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from fic_teleop_bringup import cpu_placement, run_profile
from fic_teleop_bringup.teleop_launcher import Graph, NodeSpec

TWO_CPUS = len(os.sched_getaffinity(0)) >= 2


def _specs(*names: str) -> list[NodeSpec]:
    """Process specs; ``a+b`` is a group of a and b."""
    specs = []
    for name in names:
        members = [NodeSpec("pkg", "exe", member) for member in name.split("+")] if "+" in name else []
        specs.append(NodeSpec("pkg", "exe", name, members=members))
    return specs


def _profile(*argv: str) -> dict:
    from fic_teleop_bringup import teleop_launcher

    args = teleop_launcher.parse_arguments(list(argv))
    teleop_launcher.resolve_defaults(args)
    return args.run_profile


def test_a_group_takes_its_first_named_members_cpu_and_an_unnamed_node_is_left_to_the_scheduler() -> None:
    placement = {"replica": 0, "channel_backward": 0, "haptic_device": 1, "master": 0}
    specs = _specs("replica", "haptic_device+master", "fd_adapter+channel_backward", "keyboard_operator")
    assert cpu_placement.assign(placement, specs, [4, 7]) == {
        "replica": 4, "haptic_device+master": 7, "fd_adapter+channel_backward": 4}
    # An index past the usable CPUs wraps around them; one usable CPU (or no placement) places nothing.
    assert cpu_placement.assign({"replica": 3}, _specs("replica"), [0, 1, 2]) == {"replica": 0}
    assert cpu_placement.assign(placement, specs, [5]) == {}
    assert cpu_placement.assign({}, specs, [0, 1]) == {}


def test_the_line_says_where_each_process_runs_or_why_none_is_placed() -> None:
    line = cpu_placement.describe({"replica": 0, "robot": 1, "planner": 0}, [0, 1], "profile")
    assert line == "CPU placement: CPU 0: replica, planner; CPU 1: robot (--cpu-placement profile)"
    assert "1 usable CPU or no placement" in cpu_placement.describe({}, [0], "profile")
    assert cpu_placement.describe({}, [0, 1], "none").startswith("CPU placement: the scheduler's")


def test_the_scheduler_places_the_nodes_unless_the_placement_is_asked_for() -> None:
    """Opt-in: a new participant's discovery work on pinned cores made the replica's ticks come further apart
    (cpu_placement.py)."""
    from fic_teleop_bringup import teleop_launcher

    assert teleop_launcher.parse_arguments([]).cpu_placement == "none"
    assert teleop_launcher.parse_arguments(["--cpu-placement", "profile"]).cpu_placement == "profile"


def test_the_realtime_profile_gives_the_linked_robot_and_replica_a_core_and_lockstep_places_nothing() -> None:
    realtime = _profile()["cpu_placement"]
    assert realtime["replica"] == realtime["robot"]   # one process (the realtime node groups), one core
    others = {name: cpu for name, cpu in realtime.items() if name not in ("robot", "replica")}
    assert set(others.values()) == {1 - realtime["robot"]}
    # cpu_placement replaces as a whole: lockstep's empty map is not merged into realtime's.
    assert _profile("--time-mode", "lockstep")["cpu_placement"] == {}
    assert set(realtime) <= set(run_profile.NODES)


@pytest.mark.skipif(not TWO_CPUS, reason="needs two usable CPUs")
def test_a_started_process_and_the_threads_it_starts_run_on_its_cpu(tmp_path: Path) -> None:
    """Graph.start pins the process before it runs (preexec), so a thread it starts later inherits the CPU."""
    cpu = sorted(os.sched_getaffinity(0))[1]
    code = ("import os, sys, threading; seen = []; t = threading.Thread(target=lambda: "
            "seen.append(sorted(os.sched_getaffinity(0)))); t.start(); t.join(); "
            "print(sorted(os.sched_getaffinity(0)), seen[0], flush=True)")
    preexec_cpu = cpu_placement.chained(None, cpu_placement.pinned(cpu))
    process = subprocess.run([sys.executable, "-c", code], preexec_fn=preexec_cpu, capture_output=True, text=True,
                             timeout=60)
    assert process.stdout.split() == [f"[{cpu}]", f"[{cpu}]"], process.stdout + process.stderr
    # The launcher's own start of a node, whose command is replaced by a stand-in that prints its affinity.
    (tmp_path / "logs").mkdir()
    graph = Graph(tmp_path / "logs")
    spec = NodeSpec("fic_teleop_planner", "planner_node", "planner", cpu=cpu)
    graph.wrap = lambda name, command: [sys.executable, "-c", code]
    graph.start(spec)
    started, process, log = graph.processes[0]
    assert process.wait(timeout=60) == 0
    log.close()
    assert (tmp_path / "logs" / "planner.log").read_text().split() == [f"[{cpu}]", f"[{cpu}]"]
