"""The whole graph through the hardware profiles against the driver twins (`--hardware-twin`, docs/HARDWARE.md):
the simulated robot speaks franka_ros2 and the simulated device forcedimension_ros2, the replica runs with the
franka_ros2 profile and the forcedimension adapter sits between device and master. One short lockstep E1 run:
every driver stream in the bag with the driver's names, frames and types, the arm inside its limits and tracking
the superimposed circle, every node stopped clean."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_stopped_clean, run_launcher, unclean_exit

pytestmark = pytest.mark.nodes
DURATION_S = 8.0
EXIT_JOINT_STATES_LOST = 4   # fic_teleop_bringup/launch_supervision.py


@pytest.fixture(scope="module")
def twin_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("hardware_twin") / "run"
    process = run_launcher(out, "--hardware-twin", "--time-mode", "lockstep", "--duration", str(DURATION_S),
                           "--no-video", "--wall-limit", "400")
    output = process.stdout + process.stderr
    (out / "launcher_output.txt").write_text(output)
    # The franka broadcaster's writer keeps 10 samples (SystemDefaultsQoS, as the driver's): a recorder that falls
    # 10 ms behind loses joint states, and the launcher must then say so with its own exit code, not pass.
    if process.returncode == EXIT_JOINT_STATES_LOST:
        metrics = json.loads((out / "report" / "metrics.json").read_text())
        assert metrics["dropped_joint_states"] > 0 and "joint states lost in the bag" in output, output[-3000:]
    else:
        assert_stopped_clean(process.returncode, output, "the launcher")
    for log in sorted((out / "logs").glob("*.log")):
        problem = unclean_exit(0, log.read_text(errors="replace"))
        assert not problem, f"{log.name}: {problem}"
    return out


def _first(bag: Path, topic: str):
    from mcap_ros2.reader import read_ros2_messages

    return next(read_ros2_messages(str(next(bag.glob("*.mcap"))), topics=[topic])).ros_msg


def test_the_drivers_streams_have_the_drivers_names_frames_and_types(twin_run: Path) -> None:
    metrics = json.loads((twin_run / "report" / "metrics.json").read_text())
    counts, types = metrics["message_counts"], metrics["topic_types"]
    bag = twin_run / "bag"
    # franka_ros2: 1 kHz joint states of an FR3 on the broadcaster's topic, the 30 Hz joint_state_publisher on
    # /joint_states (not recorded: the replica does not read it), the external wrench in frame "base"
    assert counts["/franka/joint_states"] >= 0.9 * 1000 * DURATION_S
    assert list(_first(bag, "/franka/joint_states").name) == [f"fr3_joint{k}" for k in range(1, 8)]
    wrench = "/franka_robot_state_broadcaster/external_wrench_in_base_frame"
    assert _first(bag, wrench).header.frame_id == "base"
    assert types["/effort_controller/commands"] == "std_msgs/msg/Float64MultiArray"
    # forcedimension_ros2: the handle's pose in fd_base, the force command as three doubles
    assert _first(bag, "/fd/ee_pose").header.frame_id == "fd_base"
    assert types["/fd/fd_controller/commands"] == "std_msgs/msg/Float64MultiArray"
    assert len(_first(bag, "/fd/fd_controller/commands").data) == 3
    # the adapter carries the device into the master's topics, and the master's force back to the device
    for topic in ("/haptic/pose", "/haptic/wrench_command", "/fd/fd_controller/commands"):
        assert counts[topic] > 0.8 * 250 * (DURATION_S - 1.0), (topic, counts[topic])


def test_the_arm_stays_in_its_limits_and_tracks_through_the_profiles(twin_run: Path) -> None:
    metrics = json.loads((twin_run / "report" / "metrics.json").read_text())
    assert metrics["limit_violations"] == 0
    # Five 12 s lockstep pairs on a quiet machine (docs/HARDWARE.md): the twin 41-55 / 10.5-14.3 mm free-motion
    # error max / RMS, the default graph 40-55 / 10.9-15.3 mm. Bounds: twice x_b = 50 mm (the FIC saturates its
    # force beyond x_b) and x_b for the RMS; a replica that kept gravity in its command (the arm compensating it
    # too) or lost the planner's motion would leave them.
    assert metrics["free_motion_error_max_m"] < 0.1
    assert metrics["free_motion_error_rms_m"] < 0.05
    # The arm moved: the superimposed circle (10 cm across) shows in the simulator's TCP.
    from mcap_ros2.reader import read_ros2_messages

    tcp = np.array([[m.ros_msg.pose.position.x, m.ros_msg.pose.position.y] for m in read_ros2_messages(
        str(next((twin_run / "bag").glob("*.mcap"))), topics=["/sim/tcp_pose"])])
    assert np.ptp(tcp[:, 0]) > 0.05 and np.ptp(tcp[:, 1]) > 0.05, np.ptp(tcp, axis=0)
