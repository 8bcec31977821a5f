"""Every node stops cleanly on SIGINT and SIGTERM at any moment: 20 start/stop cycles at random stop times.

Before (docs/RESULTS.md, fault table): a Ctrl-C crashed haptic_device_node in its spin loop (pybind11 "Unable to
convert call argument" RuntimeError, exit 1) in 1 of 2 runs, and "[FATAL] Exception in 'timers' callback" was
printed at shutdown 19 times across 17 runs. A node stopped here must exit 0 with no traceback and no FATAL line,
whether the signal comes during its imports, while it builds itself, before its first message or while it runs.
"""
from __future__ import annotations

import os
import random
import signal
import subprocess
import time
from pathlib import Path

import pytest
from conftest import CONFIG, installed_executable

from fic_teleop_bringup.launch_supervision import die_with_launcher

pytestmark = pytest.mark.nodes

# (package, executable, params file, parameters): each the way the launcher starts it, realtime.
NODES = [
    ("sim_bridge", "robot_node", "robot.yaml", {"scene": "free_space"}),
    ("fic_teleop_replica", "replica_node", "replica.yaml", {"control_rate": 500.0}),
    ("fic_teleop_master", "master_node", "master.yaml", {}),
    ("fic_teleop_planner", "planner_node", "planner.yaml", {}),
    ("sim_bridge", "channel_node", "channel.yaml", {}),
    ("sim_bridge", "haptic_device_node", "haptic_device.yaml", {"scene": "free_space"}),
    ("fic_teleop_tools", "recorder_node", None, {}),
]
CYCLES = 20
LATEST_STOP_S = 4.0   # stops spread from at once (Python still importing) to a running graph
SEED = 20261202


class Started:
    """A node started the way the launcher starts it (stop signals blocked until its handlers are in, SIGTERM if
    this process dies), its output in a file."""

    def __init__(self, command: list[str], env: dict[str, str], log: Path) -> None:
        self.command, self.log = command, log
        with open(log, "wb") as stream:
            self.process = subprocess.Popen(command, env=env, stdout=stream, stderr=subprocess.STDOUT,
                                            start_new_session=True, preexec_fn=die_with_launcher(os.getpid()))

    def output(self) -> str:
        return self.log.read_text(errors="replace")


def _start(package: str, executable: str, params_file: str | None, params: dict, env: dict[str, str],
           log: Path) -> Started:
    command = [str(installed_executable(package, executable)), "--ros-args"]
    if executable == "channel_node":  # config/channel.yaml holds the routes under the launcher's node names
        command += ["-r", "__node:=channel_forward"]
    if params_file:
        command += ["--params-file", str(CONFIG / params_file)]
    for key, value in params.items():
        command += ["-p", f"{key}:={value}"]
    return Started(command, env, log)


@pytest.mark.timeout(900)
def test_twenty_start_stop_cycles_end_cleanly(ros_env, tmp_path) -> None:
    generator = random.Random(SEED)
    problems: list[str] = []
    for cycle in range(CYCLES):
        # Two nodes a cycle, talking to each other where their topics meet (robot and replica, master and device...).
        chosen = generator.sample(NODES, 2)
        running = []
        for package, executable, params_file, params in chosen:
            extra = {"bag_path": str(tmp_path / f"bag{cycle}")} if executable == "recorder_node" else {}
            node = _start(package, executable, params_file, {**params, **extra}, ros_env,
                          tmp_path / f"{cycle}-{executable}.log")
            running.append((node, generator.uniform(0.0, LATEST_STOP_S),
                            generator.choice((signal.SIGINT, signal.SIGTERM))))
        start = time.monotonic()
        for node, at, signum in sorted(running, key=lambda item: item[1]):
            time.sleep(max(0.0, start + at - time.monotonic()))
            node.process.send_signal(signum)
        for node, at, signum in running:
            try:
                code = node.process.wait(timeout=30.0)
            except subprocess.TimeoutExpired:  # a hung node is a failure too
                node.process.kill()
                node.process.wait()
                code = "hung"
            output = node.output()
            bad = [line for line in output.splitlines()
                   if "Traceback" in line or "[FATAL]" in line or "Exception in" in line]
            if code != 0 or bad:
                problems.append(f"cycle {cycle}: {node.command[0].rsplit('/', 1)[-1]} {signal.Signals(signum).name} "
                                f"at {at:.2f} s -> exit {code}; {bad[:3]}")
    assert not problems, "\n".join(problems)
