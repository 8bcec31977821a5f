"""The launcher's real-time scheduling (fic_teleop_bringup/realtime_scheduling.py) on a real child process with real
threads, and the launcher's refusal to overwrite a run: which threads get SCHED_FIFO, that no other does (nor a thread
started later), and what happens when the OS refuses."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from conftest import REPO, SAFETY_KEPT_EXITS

from fic_teleop_bringup.realtime_scheduling import RealtimeScheduler, loop_threads

# A child with the thread kinds a node has: its main thread, a thread that keeps the process's name (like rclpy's
# timer thread), the robot's "physics" thread, a Fast DDS shared-memory receive thread, and Fast DDS threads that
# must stay in the normal class (event thread, shared-memory watchdog). On "spawn" on stdin, the main thread starts
# one more, which keeps the process's name. All of them start in the normal class.
CHILD = textwrap.dedent("""
    import os, sys, threading, time
    from sim_bridge.os_thread import name_os_thread

    # Start in the normal class whatever the test runner runs under: a runner started under a real-time policy
    # hands it to its children and to every thread they start, and the test is about what the scheduler changes.
    os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))

    lock = threading.Lock()

    def named(name):
        def run():
            if name:
                name_os_thread(name)
            with lock:  # one whole line per thread
                print("tid", name or "worker", threading.get_native_id(), flush=True)
            time.sleep(120)
        threading.Thread(target=run, daemon=True).start()

    for name in ("physics", "dds.shm.7411", "dds.udp.24169", "dds.shm.wdog", "dds.ev.0", "dds.asyn.0.0", ""):
        named(name)
    for line in sys.stdin:
        if line.strip() == "spawn":
            named("")
""")


@pytest.fixture
def child():
    """The child process and its thread ids by name."""
    process = subprocess.Popen([sys.executable, "-c", CHILD], stdin=subprocess.PIPE,
                               stdout=subprocess.PIPE, text=True)
    tids = {}
    for _ in range(7):
        _, name, tid = process.stdout.readline().split()
        tids[name] = int(tid)
    tids["main"] = process.pid
    assert all(_policy(tid) == os.SCHED_OTHER for tid in tids.values())  # before any scheduler touched them
    yield process, tids
    process.kill()
    process.wait()


def _policy(tid: int) -> int:
    return os.sched_getscheduler(tid) & ~os.SCHED_RESET_ON_FORK


def _may_use_fifo() -> bool:
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO | os.SCHED_RESET_ON_FORK, os.sched_param(1))
    except OSError:
        return False
    os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    return True


def test_only_the_loop_threads_are_chosen(child) -> None:
    _, tids = child
    chosen = set(loop_threads(tids["main"]))
    assert chosen == {tids["main"], tids["worker"], tids["physics"], tids["dds.shm.7411"], tids["dds.udp.24169"]}


def test_the_loop_threads_run_fifo_and_nothing_else_does(child) -> None:
    process, tids = child
    waiting = RealtimeScheduler(settle=600.0)  # a process still starting is left alone
    waiting.register("robot", process.pid, 42)
    waiting.apply()
    assert waiting.summary()["robot"]["threads"] == 0 and not waiting.refused()
    scheduler = RealtimeScheduler(settle=0.0)
    scheduler.register("robot", process.pid, 42)
    scheduler.apply()
    if not _may_use_fifo():  # an unprivileged machine: refused, said so, and nothing changed
        assert "robot" in scheduler.refused()
        assert scheduler.summary()["robot"]["policy"] == "refused"
        assert all(_policy(tid) == os.SCHED_OTHER for tid in tids.values())
        return
    for name in ("main", "worker", "physics", "dds.shm.7411", "dds.udp.24169"):
        assert _policy(tids[name]) == os.SCHED_FIFO, name
        assert os.sched_getparam(tids[name]).sched_priority == 42
    for name in ("dds.shm.wdog", "dds.ev.0", "dds.asyn.0.0"):
        assert _policy(tids[name]) == os.SCHED_OTHER, name
    # A thread the FIFO main thread starts afterwards does not inherit FIFO (SCHED_RESET_ON_FORK).
    process.stdin.write("spawn\n")
    process.stdin.flush()
    _, name, tid = process.stdout.readline().split()
    assert name == "worker" and _policy(int(tid)) == os.SCHED_OTHER
    assert scheduler.summary()["robot"] == {"policy": "fifo", "priority": 42, "threads": 5}
    scheduler.apply()  # again: the late thread is one of the loop's (named like the process) and now joins
    assert scheduler.summary()["robot"]["threads"] == 6 and _policy(int(tid)) == os.SCHED_FIFO


def test_a_gone_process_and_a_bad_priority() -> None:
    scheduler = RealtimeScheduler(settle=0.0)
    with pytest.raises(ValueError, match="1..99"):
        scheduler.register("replica", os.getpid(), 0)
    process = subprocess.Popen([sys.executable, "-c", "pass"])
    process.wait()
    scheduler.register("replica", process.pid, 10)
    scheduler.apply()  # the process is gone: nothing to do, no error
    assert scheduler.summary()["replica"]["threads"] == 0
    assert loop_threads(process.pid) == []


def test_the_launcher_refuses_to_overwrite_a_bag(tmp_path: Path) -> None:
    """The recorder would refuse the folder, and the report would then describe the old run as if it were new."""
    bag = tmp_path / "run" / "bag"
    bag.mkdir(parents=True)
    (bag / "old_0.mcap").write_bytes(b"old")
    result = subprocess.run([sys.executable, str(REPO / "scripts" / "teleop_launcher.py"), "--out",
                             str(tmp_path / "run"), "--duration", "1"], capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert "already holds a bag" in result.stderr
    assert not (tmp_path / "run" / "logs").exists()  # refused before any node started
    assert (bag / "old_0.mcap").read_bytes() == b"old"


def test_the_launcher_refuses_fifo_in_lockstep(tmp_path: Path) -> None:
    result = subprocess.run([sys.executable, str(REPO / "scripts" / "teleop_launcher.py"), "--out",
                             str(tmp_path / "run"),
                             "--time-mode", "lockstep", "--scheduling", "fifo"], capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 2 and "for realtime runs" in result.stderr


@pytest.mark.nodes
def test_a_fifo_run_puts_every_loop_under_fifo_and_says_so(tmp_path: Path, ros_env: dict[str, str]) -> None:
    """A short realtime run of the whole graph with --scheduling fifo: run.json lists each loop's node with its
    priority and the threads it got (the main thread and at least one shared-memory thread each; the robot also its
    physics thread), or, where the OS refuses, says so and the launcher warns."""
    out = tmp_path / "run"
    result = subprocess.run([sys.executable, str(REPO / "scripts" / "teleop_launcher.py"), "--out", str(out),
                             "--duration", "4", "--scheduling", "fifo", "--no-report"], env=ros_env,
                            capture_output=True, text=True, timeout=240)
    assert result.returncode in SAFETY_KEPT_EXITS, result.stdout + result.stderr
    import json
    applied = json.loads((out / "run.json").read_text())["realtime_scheduling"]
    assert set(applied) == {"robot", "replica", "channel_forward", "channel_backward", "master", "haptic_device",
                            "planner"}
    if not _may_use_fifo():
        assert all(entry["policy"] == "refused" for entry in applied.values())
        assert "SCHED_FIFO refused" in result.stderr
        return
    for name, entry in applied.items():
        assert entry["policy"] == "fifo" and entry["threads"] >= 2, (name, entry)
    assert applied["robot"]["priority"] > applied["replica"]["priority"] > applied["channel_forward"]["priority"] > \
        applied["master"]["priority"]
    assert applied["robot"]["threads"] >= 3  # with its physics thread
    assert "SCHED_FIFO: robot 80" in result.stdout


def test_a_launcher_started_under_fifo_leaves_it_before_starting_nodes() -> None:
    """chrt -f 10 on the launcher: it says so in one line and its process is back in the normal class, so no node it
    starts inherits the real-time policy (the refusal path returns before any node starts, after the check)."""
    if not _may_use_fifo():
        pytest.skip("this machine refuses SCHED_FIFO")
    probe = ("import os, sys; from fic_teleop_bringup.realtime_scheduling import leave_real_time_class as leave; "
             "print(leave(), leave(), os.sched_getscheduler(0) & ~os.SCHED_RESET_ON_FORK == os.SCHED_OTHER)")
    result = subprocess.run(["chrt", "-f", "10", sys.executable, "-c", probe], capture_output=True, text=True,
                            timeout=60)
    assert result.stdout.split() == ["SCHED_FIFO", "None", "True"], result.stderr
    result = subprocess.run(["chrt", "-f", "10", sys.executable, str(REPO / "scripts" / "teleop_launcher.py"),
                             "--time-mode", "lockstep", "--scheduling", "fifo"], capture_output=True, text=True,
                            timeout=60)
    assert "started under SCHED_FIFO: the launcher and its nodes run in the normal class" in result.stdout
    assert result.returncode == 2
