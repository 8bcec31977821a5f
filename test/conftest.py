"""Shared fixtures: isolated ROS 2 environments and real node processes.

Node-level tests start the installed executables (install/<pkg>/lib/<pkg>/<exe>, what `ros2 run` starts) as
real processes talking over DDS. Each test gets its own ROS_DOMAIN_ID so tests never hear each other, and
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST keeps them off the network.
"""
from __future__ import annotations

import contextlib
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
INSTALL = REPO / "install"
CONFIG = REPO / "config"
#: The launcher's exits that mean "every safety figure kept": 0, and 6 when the computer did not keep real time
#: (docs/SECURITY.md, "Exit codes of the launcher"). A test whose subject is not real-time performance (a link cut,
#: scheduling classes, isolation) accepts both: on a loaded machine its run is starved, not failed.
SAFETY_KEPT_EXITS = (0, 6)


def pytest_configure(config) -> None:
    """The suite runs in the normal scheduling class even when started under a real-time policy (some CI runners
    are): the nodes it starts would inherit it, and its timing figures assume the normal class, as the launcher
    does (fic_teleop_bringup/realtime_scheduling.py, leave_real_time_class)."""
    from fic_teleop_bringup.realtime_scheduling import leave_real_time_class
    inherited = leave_real_time_class()
    if inherited:
        print(f"[test] started under {inherited}: the suite and the nodes it starts run in the normal class")


#: What scripts/test.sh runs in the foreground at normal priority, one test at a time: every test that starts node
#: processes (the folders below, and any test marked ``nodes``) or judges the wall clock (the modules below). The rest
#: is pure computation and runs beside it in a second session at the lowest priority (nice 19), so it only takes the
#: CPU the graphs leave: on 2 cores the graphs' real-time runs keep their margin and the suite takes less wall time.
GRAPH_FOLDERS = ("nodes", "bringup")
WALL_CLOCK_MODULES = ("sim/test_stepping.py", "sim/test_peer_barrier.py", "runtime/test_periodic.py",
                      "runtime/test_shared_clock.py", "experiments/test_profile_graph.py")


@pytest.hookimpl(tryfirst=True)  # before ``-m`` selects on the marker
def pytest_collection_modifyitems(config, items) -> None:
    for item in items:
        relative = item.path.relative_to(REPO / "test").as_posix()
        if (relative.split("/")[0] in GRAPH_FOLDERS or relative in WALL_CLOCK_MODULES
                or item.get_closest_marker("nodes") is not None):
            item.add_marker(pytest.mark.graph)


# The Panda's model and datasheet limits, one of each per test module (RobotModel keeps the last state it was
# updated with, so modules do not share one).
@pytest.fixture(scope="module")
def robot():
    from fic_core.robot_model import RobotModel
    return RobotModel()


@pytest.fixture(scope="module")
def limits(robot):
    from fic_core.limits import PandaLimits
    return PandaLimits.from_robot(robot)


@contextlib.contextmanager
def reserved_domain():
    """A ROS_DOMAIN_ID no other process on this machine holds, reserved until the block ends.

    rclpy's own ``domain_coordinator`` reserves a domain by binding a port that stands for it, so two pytest
    sessions, a test and a user's run started by the launcher never share a domain. The search starts at a random
    domain so that parallel sessions do not race for the same first one.
    """
    from domain_coordinator import domain_id

    start = random.randrange(100)
    counter = iter(range(start, start + 100))
    with domain_id(selector=lambda: next(counter) % 100 + 1) as domain:
        yield domain


def installed_executable(package: str, executable: str) -> Path:
    """The file `ros2 run <package> <executable>` would start."""
    return INSTALL / package / "lib" / package / executable


def isolated_env(log_dir: Path, domain: int) -> dict[str, str]:
    """This process's environment on a private domain, localhost only, with a private log folder."""
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["ROS_LOG_DIR"] = str(log_dir)
    env["PYTHONUNBUFFERED"] = "1"
    env["RCUTILS_COLORIZED_OUTPUT"] = "0"
    return env


def run_launcher(out: Path, *arguments: str, timeout: float = 600.0) -> subprocess.CompletedProcess:
    """scripts/teleop_launcher.py run to its end on a domain of its own, writing to ``out``: a test's whole graph."""
    with reserved_domain() as domain:
        env = isolated_env(out.parent / "ros_log", domain)
        return subprocess.run([sys.executable, str(REPO / "scripts" / "teleop_launcher.py"), "--out", str(out),
                               *arguments], env=env, capture_output=True, text=True, timeout=timeout)


#: The launcher's default graph, lockstep, 3 s, no video: the run the in-process runner is compared with
#: (test_in_process_agreement) and the solo reference of runs started together (test_launcher_isolation).
DEFAULT_LOCKSTEP_RUN = ("--duration", "3", "--time-mode", "lockstep", "--no-video", "--wall-limit", "400")


@pytest.fixture(scope="session")
def default_lockstep_run(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    """One run of DEFAULT_LOCKSTEP_RUN for every test that reads it (its folder and the launcher's process); each
    test judges the exit code it needs."""
    out = tmp_path_factory.mktemp("default_lockstep") / "run"
    return out, run_launcher(out, *DEFAULT_LOCKSTEP_RUN, timeout=900.0)


@pytest.fixture
def ros_env(tmp_path: Path):
    """An environment for processes of one test: a reserved domain, localhost only, private log folder."""
    with reserved_domain() as domain:
        yield isolated_env(tmp_path / "ros_log", domain)


#: What a clean stop never prints: a Python traceback, or a line logged at FATAL severity. (Before the node runtime
#: only asked the spin loop to stop, the master and the planner logged "[FATAL] Exception in 'subscriptions' /
#: 'timers' callback" on every SIGINT; a FATAL line in a stop is a defect again.)
FATAL_IS_UNCLEAN = True
_UNCLEAN_MARKS = ("Traceback (most recent call last)", "[FATAL]")


def unclean_exit(returncode: int | None, output: str, expected_returncode: int = 0) -> str:
    """Why a process that has stopped did not stop clean ('' if it did): its exit code is not the expected one
    (0 unless the test expects a refusal), or its output holds a traceback or (for a stop that should be clean) a
    FATAL line."""
    problems = []
    if returncode != expected_returncode:
        problems.append(f"exit code {returncode} (expected {expected_returncode})")
    # A refusal to start says why in one FATAL line; only a clean stop must have none.
    marks = _UNCLEAN_MARKS if expected_returncode == 0 and FATAL_IS_UNCLEAN else _UNCLEAN_MARKS[:1]
    for mark in marks:
        if mark in output:
            line = next(line for line in output.splitlines() if mark in line)
            problems.append(f"output has {mark!r}: {line.strip()[:200]}")
    return "; ".join(problems)


def assert_stopped_clean(returncode: int | None, output: str, what: str, expected_returncode: int = 0) -> None:
    """For processes a test starts by hand: the same check as the start_node fixture's teardown."""
    problem = unclean_exit(returncode, output, expected_returncode)
    assert not problem, f"{what} did not stop clean: {problem}\n--- its output (last 3000 characters) ---\n" \
        f"{output[-3000:]}"


def recorded_so_far(bag: Path) -> int:
    """Messages in the complete chunks of a bag still being written (the project's torn-bag reader): how far a
    run has got, to wait on instead of a fixed sleep."""
    from fic_teleop_tools.recording.bag_reader import BagReadError, ReadResult, read_messages

    try:
        return sum(1 for _ in read_messages(bag, ReadResult()))
    except (BagReadError, OSError):  # not created yet
        return 0


class NodeProcess:
    """A node started as its own process; its output goes to a file the test can read.

    The start_node fixture checks at teardown that it stopped clean (``unclean_exit``); a test that expects a
    refusal sets ``expected_returncode``.
    """

    def __init__(self, command: list[str], env: dict[str, str], log_path: Path, cwd: Path | None = None) -> None:
        self.command = command
        self.expected_returncode = 0
        self.log_path = log_path
        self._log = open(log_path, "wb")
        self.process = subprocess.Popen(command, env=env, stdout=self._log, stderr=subprocess.STDOUT,
                                        start_new_session=True, cwd=cwd)

    def output(self) -> str:
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text(errors="replace")

    def wait_for_output(self, text: str, timeout: float, after: int = 0) -> bool:
        """Poll the log until ``text`` is in it (from character ``after`` on: what came later only)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if text in self.output()[after:]:
                return True
            if self.process.poll() is not None:
                return text in self.output()[after:]
            time.sleep(0.05)
        return False

    def running(self) -> bool:
        return self.process.poll() is None

    def stop(self, timeout: float = 10.0) -> int:
        """SIGINT (what Ctrl-C sends), then SIGKILL if the node does not exit; returns the exit code."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait()
        self._log.close()
        return self.process.returncode


@pytest.fixture
def start_node(ros_env: dict[str, str], tmp_path: Path):
    """Start installed node executables: start_node(pkg, exe, params={...}, params_file=..., ros_args=[...])."""
    started: list[NodeProcess] = []

    def _start(package: str, executable: str, *, params: dict | None = None, params_file: Path | None = None,
               ros_args: list[str] | None = None, env: dict[str, str] | None = None,
               name: str | None = None, cwd: Path | None = None) -> NodeProcess:
        path = installed_executable(package, executable)
        assert path.exists(), f"{path} is not installed; run scripts/setup.sh"
        command = [str(path), "--ros-args"]
        if name:
            command += ["-r", f"__node:={name}"]
        if params_file is not None:
            command += ["--params-file", str(params_file)]
        for key, value in (params or {}).items():
            command += ["-p", f"{key}:={_parameter_literal(value)}"]
        command += ros_args or []
        log = tmp_path / f"{name or executable}-{len(started)}.log"
        node = NodeProcess(command, env or ros_env, log, cwd)
        started.append(node)
        return node

    yield _start
    # Every node stops clean: exit code 0 (or the refusal the test expects), no traceback, no FATAL line.
    problems = []
    for node in started:
        returncode = node.stop()
        problem = unclean_exit(returncode, node.output(), node.expected_returncode)
        if problem:
            problems.append(f"{Path(node.command[0]).name} ({node.log_path.name}): {problem}\n"
                            f"{node.output()[-2000:]}")
    if problems:
        pytest.fail("a node did not stop clean:\n" + "\n".join(problems), pytrace=False)


def robot_and_replica(start_node):
    """The simulated robot (free space, realtime) and the replica at 500 Hz from this checkout's build, started by
    the ``start_node`` fixture: the graph the input probes write into."""
    robot = start_node("sim_bridge", "robot_node", params_file=CONFIG / "robot.yaml",
                       params={"mode": "realtime", "scene": "free_space"})
    replica = start_node("fic_teleop_replica", "replica_node", params_file=CONFIG / "replica.yaml",
                         params={"control_rate": 500.0, "diagnostics_rate": 5.0})
    return robot, replica


def _parameter_literal(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(_parameter_literal(v) for v in value) + "]"
    if isinstance(value, str):
        return value
    return repr(value)


@pytest.fixture
def rclpy_context(ros_env: dict[str, str]):
    """An rclpy context in the test process, on the test's own domain."""
    import rclpy

    previous = {key: os.environ.get(key) for key in ("ROS_DOMAIN_ID", "ROS_LOG_DIR", "ROS_AUTOMATIC_DISCOVERY_RANGE")}
    for key in previous:
        os.environ[key] = ros_env[key]
    context = rclpy.Context()
    rclpy.init(context=context)
    yield context
    # Every node the test made on it, then the context itself: a participant left alive went on announcing the
    # test's node on its domain, and a later test that reserved the same domain heard it ("domain 62 already
    # carries a graph (/test_twin, ...)" in a fresh-clone suite, 2026-12-04).
    import gc

    from rclpy.node import Node
    for node in [obj for obj in gc.get_objects() if isinstance(obj, Node) and obj.context is context]:
        with contextlib.suppress(Exception):
            node.destroy_node()
    rclpy.shutdown(context=context)
    context.destroy()
    for key, value in previous.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value


@pytest.fixture
def scratch_dir():
    with tempfile.TemporaryDirectory(prefix="fic_teleop_") as path:
        yield Path(path)
