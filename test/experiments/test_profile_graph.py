"""The node profiler's pieces (fic_teleop_experiments.tools.profile_graph): the categories a sample's stack is given
to, py-spy's raw output and perf's report read back, the per-thread CPU from /proc, and py-spy itself on a real
process (a paced loop: its sleeps must not read as CPU)."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
import threading
import time

import pytest

from fic_teleop_experiments.tools import profile_graph as pg


def test_a_sample_goes_to_the_innermost_frame_that_names_a_category_numpy_passed_over() -> None:
    publish = ["main (x.py:1)", "ReplicaNode._tick (fic_teleop_replica/replica_node.py:9)",
               "Publisher.publish (rclpy/publisher.py:70)"]
    assert pg.category(publish) == "rclpy publish (to CDR, DDS write)"
    law_in_numpy = ["spin_until_shutdown (fic_teleop_runtime/spin.py:54)", "step (fic_core/replica.py:10)",
                    "_all (numpy/_core/_methods.py:70)"]
    assert pg.category(law_in_numpy) == "fic_core (laws, stations)"   # numpy's time is its caller's
    # The law called from a callback the executor dispatched: the law, not the executor.
    assert pg.category(law_in_numpy[:2]) == "fic_core (laws, stations)"
    assert pg.category(law_in_numpy[:1]) == "executor (C++: wait, take, dispatch)"
    assert pg.category(["PandaSimulation.step (sim_bridge/robot/mujoco_panda.py:206)"]) == \
        "physics (MuJoCo step, GIL held)"
    assert pg.category(["RobotNode._run (sim_bridge/robot/robot_node.py:289)"]) == pg.OTHER
    assert pg.category([]) == pg.OTHER


def test_raw_stacks_are_read_and_summarised_in_shares_of_all_samples(tmp_path) -> None:
    raw = tmp_path / "replica.txt"
    raw.write_text("thread (1): MainThread;a (fic_core/replica.py:1) 30\n"
                   "thread (1): MainThread;b (x.py:2);Publisher.publish (rclpy/publisher.py:70) 60\n"
                   "thread (2): dds;c (y.py:3) 10\n"
                   "a malformed line\n")
    stacks = pg.read_raw(raw)
    assert stacks[0] == (["a (fic_core/replica.py:1)"], 30)   # the thread frame dropped
    summary = pg.summarise(stacks)
    assert summary["samples"] == 100
    assert summary["categories"] == {"rclpy publish (to CDR, DDS write)": 60.0, "fic_core (laws, stations)": 30.0,
                                     pg.OTHER: 10.0}
    assert summary["top_functions"]["Publisher.publish (rclpy/publisher.py)"] == 60.0


def test_perf_report_lines_are_grouped_by_thread_and_library(tmp_path, monkeypatch) -> None:
    report = ("# comment\n"
              "    23.75%\tphysics        \tlibpython3.11.so.1.0      \n"
              "    19.24%\tphysics        \t[kernel.kallsyms]         \n"
              "    10.12%\tphysics        \tlibmujoco.so.4.0.0        \n"
              "     4.89%\tdds.ev.0       \t[kernel.kallsyms]         \n"
              "     1.84%\tdds.udp.10669  \tlibfastrtps.so.2.14       \n"
              "     1.72%\tdds.udp.10671  \t[kernel.kallsyms]         \n")

    def fake_run(command, **_):
        assert command[:2] == ["perf", "report"]
        return subprocess.CompletedProcess(command, 0, stdout=report, stderr="")

    monkeypatch.setattr(pg.subprocess, "run", fake_run)
    by_thread = pg.perf_report(tmp_path / "x.perf")
    assert list(by_thread) == ["physics", "dds.ev.", "dds.udp."]   # most CPU first, thread numbers dropped
    assert by_thread["physics"] == {"Python interpreter": 23.75, "kernel": 19.24, "MuJoCo": 10.12}
    assert by_thread["dds.udp."] == {"Fast DDS and rmw": 1.84, "kernel": 1.72}   # two threads of one name, summed


def test_thread_cpu_counts_a_busy_thread_by_its_name() -> None:
    burnt, release = threading.Event(), threading.Event()

    def burn() -> None:
        end = time.thread_time() + 0.3
        while time.thread_time() < end:
            pass
        burnt.set()
        release.wait(10.0)   # alive while it is measured: a finished thread leaves /proc

    worker = threading.Thread(target=burn)
    before = pg.thread_cpu(os.getpid())
    worker.start()
    with open(f"/proc/self/task/{worker.native_id}/comm", "w") as comm:
        comm.write("burner7")   # the OS's name for it; digits are dropped when threads are grouped
    assert burnt.wait(10.0)
    spent = pg.cpu_difference(before, pg.thread_cpu(os.getpid()))
    release.set()
    worker.join()
    assert 0.25 <= spent["burner"] <= 1.0, spent
    assert pg.thread_cpu(-1) == {}   # no such process: nothing, no error


@pytest.mark.skipif(shutil.which("py-spy") is None, reason="py-spy is not installed")
def test_py_spy_with_the_gil_filter_does_not_count_a_paced_loops_sleep(tmp_path) -> None:
    """A loop of about 50 us of work and 1 ms sleeps: without --gil py-spy gave most of its samples to the sleep;
    with it (the profiler's mode), the work has the majority."""
    script = tmp_path / "paced.py"
    script.write_text(textwrap.dedent("""
        import time
        end = time.time() + 6.0
        def work():
            total = 0
            for i in range(3000):
                total += i
            return total
        while time.time() < end:
            work()
            time.sleep(0.001)
    """))
    paced = subprocess.Popen([sys.executable, str(script)])
    try:
        time.sleep(0.5)
        raw = tmp_path / "paced.txt"
        spy = subprocess.run(["py-spy", "record", "--pid", str(paced.pid), "--rate", "200", "--duration", "3",
                              "--format", "raw", "--gil", "--nonblocking", "--output", str(raw)],
                             capture_output=True, text=True, timeout=60)
        if spy.returncode != 0 and "ermission" in spy.stderr:
            pytest.skip(f"py-spy may not read another process here: {spy.stderr.strip()[-200:]}")
        assert spy.returncode == 0, spy.stderr
    finally:
        paced.kill()
        paced.wait()
    stacks = pg.read_raw(raw)
    in_work = sum(count for frames, count in stacks if any(frame.startswith("work ") for frame in frames))
    total = sum(count for _, count in stacks)
    assert total > 0 and in_work / total > 0.5, stacks
