"""The robot and the replica in one process (fic_teleop_runtime.in_process_link): the robot's physics thread runs the
replica's control step and takes its torque back without DDS, every message still goes out for the record, the
group stops clean, and a physics thread that dies ends its process with exit 1 instead of a node that does nothing.
The haptic device and the master likewise (HANDLE_LINK): the master renders the handle it is handed, and the handle
and the force still reach the bag."""
from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from conftest import REPO, isolated_env, reserved_domain, unclean_exit
from mcap_ros2.reader import read_ros2_messages

LAUNCHER = REPO / "scripts" / "teleop_launcher.py"
EXIT_STARVED = 6   # launch_supervision.py: the run's timing figures fell below their bounds (a loaded machine)


def _statistics(log: str, line: str) -> dict[str, str]:
    """The dict a node logs on its last line, ``<line>{...}``."""
    found = re.search(re.escape(line) + r"(\{.*\})", log)
    assert found, f"no {line!r} line in the log"
    return eval(found.group(1), {})   # noqa: S307 - the node's own repr of a dict of strings


@pytest.mark.nodes
def test_the_default_realtime_run_links_the_robot_and_the_replica_in_one_process(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with reserved_domain() as domain:
        process = subprocess.run([sys.executable, str(LAUNCHER), "--out", str(out), "--duration", "8", "--no-video",
                                  "--wall-limit", "300"], env=isolated_env(tmp_path / "ros_log", domain),
                                 capture_output=True, text=True, timeout=420)
    output = process.stdout + process.stderr
    assert process.returncode in (0, EXIT_STARVED), output[-3000:]   # starved on a loaded machine, never a crash
    assert "the robot and the replica linked without DDS" in output
    record = json.loads((out / "run.json").read_text())
    assert ["robot", "replica"] in record["node_groups"] and record["robot_replica_in_process"] is True
    shared = (out / "logs" / "robot+replica.log").read_text(errors="replace")
    assert not unclean_exit(0, shared), unclean_exit(0, shared)   # the group stopped clean: no traceback, no FATAL
    assert "waiting for the robot in this process" in shared
    robot = _statistics(shared, "robot_sim stopped: ")
    replica = _statistics(shared, "replica stopped: ")
    ticks = int(replica["control_ticks"])
    assert ticks > 500 * 8 * 0.8   # the 500 Hz law ran through the whole run
    # every torque reached the robot straight from the control step (none over DDS: it has no subscription)
    assert int(robot["commands_accepted"]) >= ticks - 2 and robot["commands_rejected"] == "0"
    commands = sum(1 for _ in read_ros2_messages(str(next((out / "bag").glob("*.mcap"))),
                                                 topics=["/effort_controller/commands"]))
    assert commands >= 0.95 * ticks   # ... and still went out on DDS, for the record
    metrics = json.loads((out / "report" / "metrics.json").read_text())
    assert metrics["limit_violations"] == 0 and metrics["dropped_joint_states"] == 0

    # The device and the master: linked, the operator's motion still reached the arm (the tracking figure) and the
    # handle and the force still reached the bag at their rates.
    assert "the haptic device and the master linked without DDS" in output
    assert record["device_master_in_process"] is True
    assert metrics["free_motion_error_max_m"] < 0.05
    counts = {topic: sum(1 for _ in read_ros2_messages(str(next((out / "bag").glob("*.mcap"))), topics=[topic]))
              for topic in ("/haptic/pose", "/haptic/wrench_command", "/haptic/twist")}
    assert counts["/haptic/pose"] > 250 * 8 * 0.8 and counts["/haptic/wrench_command"] > 250 * 8 * 0.8, counts
    assert counts["/haptic/twist"] == 0   # only the master read it: not published without another reader
    group = (out / "logs" / "haptic_device+master.log").read_text(errors="replace")
    assert not unclean_exit(0, group), unclean_exit(0, group)


@pytest.mark.nodes
def test_a_dead_physics_thread_ends_the_robots_process_with_exit_1(tmp_path: Path) -> None:
    """A controller whose step raises, called from the physics thread: one FATAL line naming the error, the
    process ends on its own with exit 1 (the launcher's "a node crashed"), not a robot that publishes nothing."""
    script = textwrap.dedent("""
        from fic_teleop_runtime.in_process_link import LINK
        from fic_teleop_runtime.node_main import run_entries
        from sim_bridge.robot.robot_node import ENTRY

        def broken_controller(joint_state):
            raise RuntimeError("a controller that fails")

        LINK.joint_state_reader = broken_controller
        run_entries([ENTRY], args=["--ros-args", "-r", "__node:=robot", "-p", "controller_in_process:=true"])
    """)
    with reserved_domain() as domain:
        process = subprocess.run([sys.executable, "-c", script], env=isolated_env(tmp_path / "ros_log", domain),
                                 capture_output=True, text=True, timeout=120)
    output = process.stdout + process.stderr
    assert process.returncode == 1, output[-3000:]
    fatal = [line for line in output.splitlines() if "[FATAL]" in line]
    assert len(fatal) == 1 and "physics thread failed: RuntimeError('a controller that fails')" in fatal[0]
    assert "robot_sim stopped: " in output   # its statistics still said on the way out


@pytest.mark.nodes
@pytest.mark.parametrize("setting", ["mode:=lockstep", "driver_interface:=franka_ros2"])
def test_the_link_is_refused_where_it_cannot_work(tmp_path: Path, setting: str) -> None:
    """Lockstep answers each state over the step clock, and a driver twin speaks DDS as the real driver does: the
    robot refuses controller_in_process there, in one line, before anything moves."""
    with reserved_domain() as domain:
        process = subprocess.run([sys.executable, "-m", "sim_bridge.robot.robot_node", "--ros-args", "-p",
                                  "controller_in_process:=true", "-p", setting],
                                 env=isolated_env(tmp_path / "ros_log", domain), capture_output=True, text=True,
                                 timeout=120)
    assert process.returncode == 2, process.stderr[-2000:]
    assert "controller_in_process needs mode realtime and driver_interface sim" in process.stderr


@pytest.mark.nodes
def test_the_handle_link_is_refused_for_the_device_driver_twin(tmp_path: Path) -> None:
    """The forcedimension_ros2 twin speaks DDS as the real driver does: the device refuses master_in_process there,
    in one line."""
    with reserved_domain() as domain:
        process = subprocess.run([sys.executable, "-m", "sim_bridge.device.haptic_device_node", "--ros-args", "-p",
                                  "master_in_process:=true", "-p", "driver_interface:=forcedimension"],
                                 env=isolated_env(tmp_path / "ros_log", domain), capture_output=True, text=True,
                                 timeout=120)
    assert process.returncode == 2, process.stderr[-2000:]
    assert "master_in_process needs driver_interface sim" in process.stderr
