"""Which CPU each node process runs on: the run profile's ``cpu_placement``, with ``--cpu-placement profile``
(opt-in; docs/ARCHITECTURE.md, "Bringup").

On this machine kind (2 cores) the graph's processes wake each other thousands of times a second, and left to the
scheduler they move between the cores as they wake, each time onto a core whose caches hold another process's work.
Measured (docs/RESULTS.md, "Graph levers", 4 alternated rounds): placed on fixed cores, the main job used 48.8-50.5
CPU-s against 51.2-53.1, with a lower latency p99 (2.4-3.9 against 3.5-4.2 ms); the replica's law cost 316 against
351 us of CPU a tick (116 us in process: most of the graph's overhead per tick is not the placement's to remove).
The placement splits the two loops that close through the robot: the replica (with its planner and the forward
channel, which feed it) on one core, the robot's physics (with the haptic device and the master, whose 250 Hz loops
pace themselves, and the recorder) on the other. The replica and the robot on one core took turns on it and tracked
worse (error max 40-42 against 34-36 mm, 3 runs).

Why it is not the default: a pinned process cannot leave its core, and neither can its middleware threads. When a
new participant joins the graph (a user's ``ros2 topic list``, the bench's graph census), every process's discovery
work lands on the cores at once; placed, the replica's longest control tick gap was 25-45 ms against 15-22 ms left to
the scheduler (3 alternated pairs), and 2 of 20 placed bench runs held the arm (ticks 55 and 67 ms apart) as the census
started, a starved run. A busy neighbour without DDS did not hurt it (3 of 3 exit 0 against 2 of 3). On a machine that
runs the graph and nothing else, the placement is the cheaper layout; where users poke the running graph, the
scheduler's is the safer one.

A placement names a node and an index into the CPUs the launcher itself may use (its affinity, so a cgroup's cpuset
or a ``taskset`` around the launcher is kept): index i is the i-th of them, modulo their number. A node group runs on
its first member's CPU. A node the profile does not name, and every node on a machine with one usable CPU, is left to
the scheduler. Threads a process starts later (Fast DDS's, the robot's physics thread) inherit its CPU. Like
ros2_control's ``cpu_affinity`` of its controller manager, this is placement only: it does not change a thread's
priority (the profile's niceness does).
"""
from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping

PLACEMENTS = ("none", "profile")


def usable_cpus() -> list[int]:
    """The CPUs this process may run on, in order."""
    return sorted(os.sched_getaffinity(0))


def assign(placement: Mapping[str, int], specs: Iterable, cpus: list[int]) -> dict[str, int]:
    """Process name -> CPU for the graph's ``specs`` (a group by its first named member); empty with fewer than
    two usable CPUs (nothing to spread) or no placement."""
    if len(cpus) < 2 or not placement:
        return {}
    assigned = {}
    for spec in specs:
        names = [member.name for member in spec.members] or [spec.name]
        index = next((placement[name] for name in names if name in placement), None)
        if index is not None:
            assigned[spec.name] = cpus[index % len(cpus)]
    return assigned


def pinned(cpu: int | None) -> Callable[[], None] | None:
    """A preexec step that runs the process on ``cpu`` (refused, e.g. by a cpuset that lost the CPU: left as it
    is, and the launcher's line still says what it asked)."""
    if cpu is None:
        return None

    def apply() -> None:
        try:
            os.sched_setaffinity(0, {cpu})
        except OSError:
            pass
    return apply


def describe(assigned: Mapping[str, int], cpus: list[int], chosen: str) -> str:
    """One line for the run's output: which processes run on which CPU, or why none is placed."""
    if chosen == "none":
        return "CPU placement: the scheduler's (--cpu-placement profile: the run profile's, fic_teleop_bringup/" \
               "cpu_placement.py)"
    if not assigned:
        return f"CPU placement: none ({len(cpus)} usable CPU{'s' if len(cpus) != 1 else ''} or no placement in the " \
               "profile): the scheduler places every node"
    by_cpu: dict[int, list[str]] = {}
    for name, cpu in assigned.items():
        by_cpu.setdefault(cpu, []).append(name)
    return "CPU placement: " + "; ".join(f"CPU {cpu}: {', '.join(names)}" for cpu, names in sorted(by_cpu.items())) \
        + " (--cpu-placement profile)"


def chained(*steps: Callable[[], None] | None) -> Callable[[], None] | None:
    """The preexec steps that are given, in order, as one (None if none is)."""
    given = [step for step in steps if step is not None]
    if not given:
        return None

    def apply() -> None:
        for step in given:
            step()
    return apply
