"""The launcher refuses, in one line and before any node starts, every option the graph cannot run with."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from conftest import REPO

from fic_teleop_bringup.launch_supervision import (
    EXIT_INPUT_REFUSED,
    EXIT_JOINT_STATES_LOST,
    EXIT_LIMIT_VIOLATIONS,
    EXIT_NODE_FAILED,
    EXIT_OK,
    EXIT_REFUSED,
    safety_verdict,
)

LAUNCHER = REPO / "scripts" / "teleop_launcher.py"


def _launch(tmp_path: Path, *arguments: str, out: Path | None = None) -> subprocess.CompletedProcess:
    out_arguments = [] if "--out" in arguments else ["--out", str(out or tmp_path / "run")]
    return subprocess.run([sys.executable, str(LAUNCHER), *out_arguments, *arguments], capture_output=True,
                          text=True, timeout=120)


@pytest.mark.parametrize("arguments, words", [
    (("--duration", "inf"), "--duration [s] must be a finite number"),
    (("--duration", "0"), "--duration [s] must be in (0, 86400]"),
    (("--delay", "nan"), "--delay [s] must be a finite number"),
    (("--delay", "-0.1"), "--delay [s] must be in [0, 60]"),
    (("--jitter", "inf"), "--jitter [s] must be a finite number"),
    (("--drop", "1.5"), "--drop (a probability) must be in [0, 1]"),
    (("--rate-cap", "-1"), "--rate-cap [Hz] (0: none) must be in [0, 10000]"),
    (("--control-rate", "0"), "--control-rate [Hz] must be in [1, 1000]"),
    (("--control-rate", "nan"), "--control-rate [Hz] must be a finite number"),
    (("--blackout-window", "5", "3"), "--blackout-window must end after it starts"),
    (("--blackout-at", "nan"), "--blackout-at [s] must be a finite number"),
    (("--wall-limit", "inf"), "--wall-limit [s] must be a finite number"),
    (("--domain-id", "300"), "--domain-id must be 0-101 or 215-232"),
    (("--domain-id", "-1"), "--domain-id must be 0-101 or 215-232"),
    (("--seed", "-3"), "--seed must be in [0, 2^62)"),
    (("--joint-state-rate", "300"), "--joint-state-rate must divide 1000 Hz (the physics steps), got 300"),
    (("--joint-state-rate", "250"), "--joint-state-rate 250 Hz is below the replica's control rate 500 Hz"),
    (("--joint-state-rate", "500", "--time-mode", "lockstep"), "--joint-state-rate is for realtime runs"),
    (("--joint-state-rate", "500", "--hardware-twin"), "--joint-state-rate: the driver twin publishes at the Franka "
                                                       "broadcaster's 1000 Hz"),
    (("--joint-state-rate", "500", "--control-rate", "300"), "--joint-state-rate 500 Hz: the replica's control rate "
                                                             "300 Hz must tick on every n-th joint state"),
    (("--joint-state-rate", "nan"), "--joint-state-rate [Hz] must be a finite number"),
    (("--params-file", "replica"), "--params-file needs NODE=FILE, got 'replica'"),
    (("--params-file", "replica=/nonexistent/rates.yaml"), "--params-file replica: /nonexistent/rates.yaml is not a "
                                                           "readable file"),
    (("--operator", "closed-loop", "--scene", "free_space"),
     "--operator closed-loop drives the superimposition scene's scripted run only"),
])
def test_an_unusable_option_is_one_line_and_nothing_starts(tmp_path: Path, arguments, words) -> None:
    result = _launch(tmp_path, *arguments)
    assert result.returncode == EXIT_REFUSED, result.stdout + result.stderr
    lines = result.stderr.strip().splitlines()
    assert lines == [f"[run] refused: {words}" + lines[0].split(words, 1)[1]], result.stderr
    assert "Traceback" not in result.stdout + result.stderr
    assert not (tmp_path / "run").exists()  # checked before the run folder, the domain or any node


@pytest.mark.parametrize("make_out", [
    lambda tmp: (tmp / "file").write_text("") or tmp / "file",              # a file where the folder should be
    lambda tmp: (tmp / "file").write_text("") or tmp / "file" / "run",      # below a file
    lambda tmp: Path("/proc/fic_teleop_run"),                               # a file system that refuses folders
])
def test_an_unusable_out_is_one_line(tmp_path: Path, make_out) -> None:
    out = make_out(tmp_path)
    result = _launch(tmp_path, "--out", str(out), "--no-report")
    assert result.returncode == EXIT_REFUSED, result.stdout + result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"[run] refused: --out {out} cannot be the run folder"), \
        result.stderr
    assert "Traceback" not in result.stderr


def test_an_out_that_holds_a_bag_is_refused(tmp_path: Path) -> None:
    (tmp_path / "run" / "bag").mkdir(parents=True)
    (tmp_path / "run" / "bag" / "old.mcap").write_bytes(b"x")
    result = _launch(tmp_path, "--no-report")
    assert result.returncode == EXIT_REFUSED and "already holds a bag" in result.stderr


def test_the_verdict_names_each_broken_figure_worst_first() -> None:
    clean = {"limit_violations": 0, "dropped_joint_states": 0}
    assert safety_verdict(clean, {"robot": 0, "replica": -2}, [], False) == (EXIT_OK, [])
    code, reasons = safety_verdict({"limit_violations": 22, "dropped_joint_states": 5}, {"robot": 0}, [], False)
    assert code == EXIT_LIMIT_VIOLATIONS and reasons == ["22 limit-violation ticks", "5 joint states lost in the bag"]
    code, _ = safety_verdict({"limit_violations": 0, "dropped_joint_states": 3}, {}, [], False)
    assert code == EXIT_JOINT_STATES_LOST
    code, reasons = safety_verdict(clean, {"haptic_device": 1}, ["haptic_device"], False)
    assert code == EXIT_NODE_FAILED and "haptic_device (1)" in reasons[0]
    assert EXIT_INPUT_REFUSED not in (EXIT_OK, EXIT_REFUSED, EXIT_NODE_FAILED, EXIT_LIMIT_VIOLATIONS)


def test_a_node_killed_at_the_stop_of_a_starved_run_is_starvation_not_a_crash() -> None:
    """A node the launcher had to kill because it had not stopped on SIGINT in time: on a starved machine the run is
    starved (exit 6, the kill named with the timing verdict), not "a node crashed"; on a machine that kept real time
    it is a failed node, named as killed."""
    from fic_teleop_bringup.launch_supervision import EXIT_STARVED
    from fic_teleop_bringup.launch_timing import Timing, TimingBounds, exit_code

    clean = {"limit_violations": 0, "dropped_joint_states": 0}
    codes = {"robot": 0, "replica": -2, "haptic_device+master": -9}
    starved = Timing(judged=True, bounds=TimingBounds(0.95, 0.9, 0.9), starved=True,
                     reasons=["real-time factor 0.545 < 0.95"],
                     figures={"killed_at_stop": ["haptic_device+master"]})
    code, reasons = safety_verdict(clean, codes, [], False, killed_at_stop=["haptic_device+master"], starved=True)
    assert (code, reasons) == (EXIT_OK, [])
    assert exit_code(code, starved, EXIT_STARVED) == EXIT_STARVED
    assert any("killed at the stop" in line and "haptic_device+master" in line for line in starved.lines())
    code, reasons = safety_verdict(clean, codes, [], False, killed_at_stop=["haptic_device+master"], starved=False)
    assert code == EXIT_NODE_FAILED and reasons == [
        "nodes killed at the stop, still running long after SIGINT on a machine that kept real time: "
        "haptic_device+master"]
    # a node that crashed on its own is still a crash, starved or not
    code, reasons = safety_verdict(clean, {**codes, "planner": 1}, [], False,
                                   killed_at_stop=["haptic_device+master"], starved=True)
    assert code == EXIT_NODE_FAILED and reasons == ["nodes exited with errors: planner (1)"]


def test_the_graph_kills_a_node_that_ignores_its_stop_and_names_it(tmp_path: Path) -> None:
    """Graph.stop: SIGINT, then SIGKILL after the timeout; the killed node is in killed_at_stop, a node that stops
    on SIGINT is not."""
    from fic_teleop_bringup.teleop_launcher import Graph, NodeSpec

    graph = Graph(tmp_path)
    stubborn = "import signal, sys, time; signal.signal(signal.SIGINT, signal.SIG_IGN); print(1, flush=True); " \
               "time.sleep(60)"
    # Its SIGINT handler set, not inherited: a shell's background job (`cmd &`, as a CI runner may start the suite)
    # starts with SIGINT ignored, and Python then installs no KeyboardInterrupt handler of its own.
    willing = ("import signal, sys, time; signal.signal(signal.SIGINT, signal.default_int_handler); "
               "print(1, flush=True); time.sleep(60)")
    for name, code in (("robot", willing), ("haptic_device+master", stubborn)):
        process = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE)
        assert process.stdout.readline().strip() == b"1"   # its handler is in
        graph.processes.append((NodeSpec("pkg", "exe", name), process, None))
    codes = graph.stop(timeout=5.0)   # a loaded machine can take more than 0.5 s to end the willing one
    assert graph.killed_at_stop == ["haptic_device+master"]
    assert codes["haptic_device+master"] == -9 and codes["robot"] == -2


def test_a_refusal_recorded_in_the_bag_is_named_with_its_reason(tmp_path: Path) -> None:
    """The replica's /diagnostics in the bag carry its refusal count and the last reason; the verdict quotes it."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from rclpy.serialization import serialize_message

    from fic_teleop_tools.recording.bag_writer import BagWriter

    def status(refused: str, reason: str) -> bytes:
        values = {"input_safe_hold": "no", "refused_teleop_commands": refused, "clamped_teleop_commands": "0",
                  "last_refusal": reason}
        return serialize_message(DiagnosticArray(status=[DiagnosticStatus(
            name="replica", values=[KeyValue(key=k, value=v) for k, v in values.items()])]))

    def bag(name: str, *statuses: bytes) -> Path:
        writer = BagWriter(tmp_path / name)
        writer.add_topic("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray")
        for k, message in enumerate(statuses):
            writer.write("/diagnostics", message, (k + 1) * 1_000_000_000)
        writer.finish()
        return tmp_path / name

    clean = {"limit_violations": 0, "dropped_joint_states": 0}
    assert safety_verdict(clean, {}, [], False, bag("clean", status("0", "none"))) == (EXIT_OK, [])
    code, reasons = safety_verdict(clean, {}, [], False, bag("refused", status("0", "none"), status(
        "1", "stamped 3.4 s in the past (at most 3.2 s)")))
    assert code == EXIT_INPUT_REFUSED
    assert reasons == ["the replica refused 1 teleoperation commands (the last: stamped 3.4 s in the past (at most "
                       "3.2 s)) and clamped 0 onto its workspace"]


def test_the_robots_velocity_reflex_in_the_bag_is_a_limit_violation(tmp_path: Path) -> None:
    """The robot's /diagnostics record of its velocity reflex fails the run with the limit-violation code, even
    when the replica (starved, say) counted no violation; an empty record passes."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from rclpy.serialization import serialize_message

    from fic_teleop_tools.recording.bag_writer import BagWriter

    def bag(name: str, reflex: str) -> Path:
        writer = BagWriter(tmp_path / name)
        writer.add_topic("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray")
        for k, text in enumerate(("", reflex)):
            writer.write("/diagnostics", serialize_message(DiagnosticArray(status=[DiagnosticStatus(
                name="robot_sim", values=[KeyValue(key="reflex", value=text)])])), (k + 1) * 1_000_000_000)
        writer.finish()
        return tmp_path / name

    clean = {"limit_violations": 0, "dropped_joint_states": 0}
    assert safety_verdict(clean, {}, [], False, bag("calm", "")) == (EXIT_OK, [])
    code, reasons = safety_verdict(clean, {}, [], False, bag("stopped", "reflex: panda_joint2 moved at 2.300 rad/s"))
    assert code == EXIT_LIMIT_VIOLATIONS
    assert reasons == ["the robot stopped the arm: reflex: panda_joint2 moved at 2.300 rad/s"]


@pytest.mark.parametrize("arguments, rate", [
    ([], 500.0),                                        # realtime: the replica's rate, the A/B's best
    (["--control-rate", "1000"], 1000.0),               # a faster replica gets every step
    (["--control-rate", "250"], 500.0),                 # a tick every second state
    (["--control-rate", "300"], 1000.0),                # 3.3 ms is no whole number of 2 ms: every step
    (["--joint-state-rate", "1000"], 1000.0),           # asked for
    (["--hardware-twin"], None),                        # the Franka broadcaster's own 1 kHz
    (["--time-mode", "lockstep"], None),                # every step, the replica answers each
])
def test_the_default_joint_state_rate_follows_the_mode(arguments, rate) -> None:
    from fic_teleop_bringup import teleop_launcher

    args = teleop_launcher.parse_arguments(arguments)
    teleop_launcher.resolve_defaults(args)
    assert args.joint_state_rate == rate
    robot, recorder = (next(s for s in teleop_launcher.graph(args, Path("bag")) if s.name == name)
                       for name in ("robot", "recorder"))
    assert robot.params.get("joint_state_rate_hz") == rate
    assert recorder.params.get("joint_states_period") == (None if rate is None else 1.0 / rate)


def test_a_params_file_goes_to_its_node_after_its_config_and_an_unknown_node_is_refused(tmp_path: Path) -> None:
    from fic_teleop_bringup import teleop_launcher
    from fic_teleop_bringup.launch_checks import ArgumentRefusal

    rates = tmp_path / "rates.yaml"
    rates.write_text("/**:\n  ros__parameters:\n    status_rate: 50.0\n")
    args = teleop_launcher.parse_arguments(["--params-file", f"replica={rates}"])
    teleop_launcher.resolve_defaults(args)
    replica = next(s for s in teleop_launcher.graph(args, Path("bag")) if s.name == "replica")
    command = teleop_launcher.node_command(replica, tmp_path / "run_params.yaml")
    files = [command[i + 1] for i, item in enumerate(command) if item == "--params-file"]
    assert files[0].endswith("config/replica.yaml") and files[-2:] == [str(rates), str(tmp_path / "run_params.yaml")]
    args = teleop_launcher.parse_arguments(["--params-file", f"replcia={rates}"])
    teleop_launcher.resolve_defaults(args)
    with pytest.raises(ArgumentRefusal, match="--params-file: no node 'replcia' in this graph"):
        teleop_launcher.graph(args, Path("bag"))
