"""Real-time (SCHED_FIFO) scheduling for the threads of the teleoperation loop: ``--scheduling fifo``, opt-in.

Why it exists: on 2 cores the graph uses most of both, and under the normal scheduler a message waits for a core
at every hop; the pipeline latency p99 of the default main job is 16-31 ms with the loops at negative niceness
(the default, ``--scheduling nice``) against the 5 ms target (docs/EXPERIMENTS.md). With the loops' threads under
SCHED_FIFO, each receiver pre-empts its sender: measured 2026-12-02 in 11 runs of the default job with this thread
choice, p50 1.3-2.6 ms and p99 2.9-10.1 ms in 9 (the other two 15 and 26 ms), against 16-31 ms in the nice runs in
between. With it the launcher sets the replica's ``tick_on_command``.

Why it is not the default: what the FIFO threads leave is too little for the normal class on 2 cores (the graph
needs about 180 % of the machine). The recorder, which must stay behind the loops, then fell more than a second
behind and lost 590-10,541 of the 30,000 joint states in 10 of those 11 runs; given FIFO itself (below the
loops) it lost 5,209. On a machine with cores to spare, or with the recorder elsewhere, this is what a deployment of
these loops would use.

Which threads: in each node process, every thread named like the process (the main thread that runs the
callbacks, rclpy's timer thread), a thread the node named ``physics`` (the robot's simulation loop,
sim_bridge/os_thread.py) and Fast DDS's receive threads of a port (``dds.shm.<port>`` with shared memory,
``dds.udp.<port>`` with the default loopback UDP profile, config/fastdds_loopback_udp.xml), once the process has
run SETTLE_S (its threads are all there). Not Fast DDS's event, asynchronous-send and watchdog threads. Threads
started later come out in the normal class (SCHED_RESET_ON_FORK). The launcher sets OPENBLAS_NUM_THREADS=1: OpenBLAS's
workers busy-wait after each call, which a FIFO thread must never do (``chrt -a`` on every thread of the
replica and the robot made both spin at 100 % of a core).

Priorities follow the data path, so that each receiver pre-empts its sender: the physics (the plant steps on
time) above the replica, above the forward channel, above the master and the haptic device, above the planner and
the backward channel. The kernel's real-time throttling (kernel.sched_rt_runtime_us, 950000 of every 1000000 us
by default) leaves the normal class at least 5 % of the machine even if a loop ran away.

Needs root or CAP_SYS_NICE; refused, the node keeps its niceness and the launcher says so.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

# Node name -> SCHED_FIFO priority (1-99; higher pre-empts lower): the run profile's fifo_priorities.
RECEIVE_THREAD_PREFIXES = ("dds.shm.", "dds.udp.")   # Fast DDS's receive threads, named by transport and port
LOOP_THREAD_NAMES = ("physics",)   # sim_bridge/robot/robot_node.py PHYSICS_THREAD_NAME
SETTLE_S = 6.0   # [s] a node process is left alone this long after its start (imports, DDS participant, executor)


def _comm(path: Path) -> str | None:
    try:
        return path.read_text().strip()
    except OSError:  # the thread or process is gone
        return None


def process_age(pid: int) -> float | None:
    """Seconds since process ``pid`` started (None if it is gone)."""
    try:
        start_ticks = int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[19])
        uptime = float(Path("/proc/uptime").read_text().split()[0])
    except (OSError, IndexError, ValueError):
        return None
    return uptime - start_ticks / os.sysconf("SC_CLK_TCK")


def loop_threads(pid: int) -> list[int]:
    """Thread ids of process ``pid`` that carry its loop: every thread named like the process (the main thread,
    rclpy's executor and timer threads), threads named in LOOP_THREAD_NAMES, and Fast DDS's receive threads."""
    process_name = _comm(Path(f"/proc/{pid}/comm"))
    try:
        tasks = list(Path(f"/proc/{pid}/task").iterdir())
    except OSError:  # the process is gone
        return []
    threads = []
    for task in tasks:
        name = _comm(task / "comm")
        if name is None:
            continue
        receives = any(name.startswith(prefix) and name[len(prefix):].isdigit() for prefix in RECEIVE_THREAD_PREFIXES)
        # The main thread is named like the process (/proc/<pid>/comm is its name).
        if name == process_name or name in LOOP_THREAD_NAMES or receives:
            threads.append(int(task.name))
    return threads


NORMAL_POLICIES = (os.SCHED_OTHER, os.SCHED_BATCH, os.SCHED_IDLE)
POLICY_NAMES = {os.SCHED_FIFO: "SCHED_FIFO", os.SCHED_RR: "SCHED_RR"}


def leave_real_time_class() -> str | None:
    """Put the calling thread back in the normal class if it was started under a real-time policy, and return
    that policy's name (None: it was in the normal class already).

    A launcher or a test runner started under SCHED_FIFO (``chrt``, some CI runners) would hand the policy to every
    node it starts and every thread they start: the DDS watchdog and event threads, OpenBLAS's busy-waiting workers
    and the recorder would all pre-empt the normal class, and the loops at one priority would no longer share a
    core. Real-time scheduling is opt-in and per thread (``RealtimeScheduler``); everything starts normal."""
    policy = os.sched_getscheduler(0) & ~os.SCHED_RESET_ON_FORK
    if policy in NORMAL_POLICIES:
        return None
    os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    return POLICY_NAMES.get(policy, f"policy {policy}")


@dataclass
class ProcessScheduling:
    """What was applied to one node's process."""
    priority: int
    threads: set[int] = field(default_factory=set)
    refused: str | None = None      # the OS error, if SCHED_FIFO was refused


class RealtimeScheduler:
    """Puts each registered process's loop threads under SCHED_FIFO at its priority.

    ``apply`` is called repeatedly while the graph starts (threads appear as a node creates its executor and its
    DDS participant) and during the run (it is cheap: a read of /proc per thread); threads already done are skipped.
    """

    def __init__(self, settle: float = SETTLE_S) -> None:
        self.settle = settle
        self.processes: dict[str, tuple[int, ProcessScheduling]] = {}

    def register(self, name: str, pid: int, priority: int) -> None:
        if not 1 <= priority <= 99:
            raise ValueError(f"SCHED_FIFO priority of {name} must be in 1..99, got {priority}")
        self.processes[name] = (pid, ProcessScheduling(priority))

    def apply(self) -> None:
        for pid, state in self.processes.values():
            if state.refused is not None:
                continue
            age = process_age(pid)
            if age is None or age < self.settle:
                continue  # still starting: its threads are not all there yet
            for thread in loop_threads(pid):
                if thread in state.threads:
                    continue
                try:
                    # RESET_ON_FORK: threads this one starts later (Fast DDS's, rclpy's) come out in the normal
                    # class instead of inheriting FIFO; the next pass picks the ones that belong here.
                    os.sched_setscheduler(thread, os.SCHED_FIFO | os.SCHED_RESET_ON_FORK,
                                          os.sched_param(state.priority))
                except ProcessLookupError:
                    continue  # the thread ended meanwhile
                except OSError as exc:  # EPERM without CAP_SYS_NICE
                    state.refused = exc.strerror or str(exc)
                    break
                state.threads.add(thread)

    def refused(self) -> dict[str, str]:
        return {name: state.refused for name, (_, state) in self.processes.items() if state.refused is not None}

    def summary(self) -> dict[str, dict]:
        return {name: {"policy": "fifo" if state.refused is None else "refused", "priority": state.priority,
                       "threads": len(state.threads), **({"error": state.refused} if state.refused else {})}
                for name, (_, state) in self.processes.items()}
