"""The closed-loop operator in the DDS graph: the device node watches the replica's video after the backward
channel and times its moves from it, as the in-process runner's operator does (docs/EXPERIMENTS.md, "Operators").

A short lockstep E1 run with ``--operator closed-loop``: the video crosses the channel with the link's delay, the
operator starts its avoid and push moves when the in-process runner's operator on the same cell does, for passings
it predicts close to those that happened; the run stays inside the arm's limits and tracks within a bound."""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import run_launcher

from sim_bridge.robot.scenes import CIRCLE_CENTRE, PUSHABLE_OBSTACLE_POSITION

pytestmark = pytest.mark.nodes
DURATION_S = 8.0
# The pushable obstacle's angle on the circle, from the scene (the ground truth the operator estimates)
PUSHABLE_OBSTACLE_ANGLE = math.atan2(PUSHABLE_OBSTACLE_POSITION[1] - CIRCLE_CENTRE[1],
                                     PUSHABLE_OBSTACLE_POSITION[0] - CIRCLE_CENTRE[0])
MOVE = re.compile(r"closed-loop operator starts its (\w+) move at ([\d.]+) s for the passing it predicts at ([\d.]+) s")


@pytest.fixture(scope="module")
def closed_loop_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("closed_loop") / "run"
    process = run_launcher(out, "--duration", str(DURATION_S), "--time-mode", "lockstep", "--operator", "closed-loop",
                           "--no-video", "--wall-limit", "400")
    assert process.returncode == 0, process.stdout + process.stderr
    return out


def test_the_video_crosses_the_link_with_its_delay(closed_loop_run: Path) -> None:
    from mcap_ros2.reader import read_ros2_messages

    mcap_file = str(next((closed_loop_run / "bag").glob("*.mcap")))
    held = {"/master/video/tcp_pose": [], "/master/video/object_poses": []}
    for message in read_ros2_messages(mcap_file, topics=["/channel/deliveries"]):
        if message.ros_msg.topic in held:
            held[message.ros_msg.topic].append(message.ros_msg.held)
    for topic, values in held.items():
        # 30 frames a second from the robot's start, less the first delay (lockstep: the link's time is sim time)
        assert len(values) > 0.8 * 30 * (DURATION_S - 1.0), (topic, len(values))
        assert np.median(values) == pytest.approx(0.2, abs=0.01), topic


def _passing_times(bag: Path, angle: float, topic: str = "/planner/desired_pose") -> list[float]:
    """When ``topic``'s pose crossed ``angle`` on the E1 circle [s, stamps]: by default the planner's x_d, the robot's
    motion without the operator's offset, which is what the operator predicts (it takes its own offset out of what
    it sees)."""
    from mcap_ros2.reader import read_ros2_messages

    stamps, angles = [], []
    for message in read_ros2_messages(str(next(bag.glob("*.mcap"))), topics=[topic]):
        position, stamp = message.ros_msg.pose.position, message.ros_msg.header.stamp
        stamps.append(stamp.sec + 1e-9 * stamp.nanosec)
        angles.append(math.atan2(position.y - CIRCLE_CENTRE[1], position.x - CIRCLE_CENTRE[0]))
    times, unwrapped = np.array(stamps), np.unwrap(angles)
    crossings = []
    for lap in range(-2, 4):
        target = angle + 2.0 * math.pi * lap
        index = np.nonzero((unwrapped[:-1] - target) * (unwrapped[1:] - target) <= 0.0)[0]
        crossings += [float(times[i]) for i in index]
    return sorted(crossings)


def test_the_operator_times_its_moves_as_the_in_process_operator_does(closed_loop_run: Path) -> None:
    from fic_teleop_experiments.in_process import RunConfig, run

    log = (closed_loop_run / "logs" / "haptic_device.log").read_text()
    graph_moves = [(name, float(start), float(passing)) for name, start, passing in MOVE.findall(log)]
    runner_moves = [move for move in run(RunConfig(duration=DURATION_S, operator="closed_loop")).operator_moves
                    if move[1] < DURATION_S - 0.5]   # the graph's last tick may come before the launcher stops it
    # The runner's operator avoids the fixed obstacle first, then pushes the pushable one: what it saw decides each.
    assert [move[0] for move in runner_moves][:2] == ["avoid", "push"], runner_moves
    # The graph's operator makes both moves, and its first push starts when the runner's does: 0-0.37 s apart in
    # nineteen lockstep runs at load 8-20 (2026-12-04/05).
    graph_names = [move[0] for move in graph_moves]
    assert "avoid" in graph_names and "push" in graph_names, graph_moves
    graph_push = next(move for move in graph_moves if move[0] == "push")
    runner_push = next(move for move in runner_moves if move[0] == "push")
    assert graph_push[1] == pytest.approx(runner_push[1], abs=0.6), (graph_moves, runner_moves)
    # Not held: the first avoid's start. It is planned from the first second of video, which shows the robot at rest
    # and then starting its circle; the median speed over it crosses the operator's 0.3 rad/s threshold at a time
    # that moves with how many frames the node took in at one tick, and the predicted passing with it (3.42-4.20 s
    # in the graph, 4.15 s in the runner). In one CI run (2026-12-06) the estimate put the first lap's passing behind
    # the move's window before it became valid, so the graph's operator skipped that avoid and avoided on lap 2
    # (moves: push 5.14 s, avoid 6.49 s for 8.01 s, push 9.06 s); its push started 0.53 s after the runner's (4.61 s).
    passings = _passing_times(closed_loop_run / "bag", PUSHABLE_OBSTACLE_ANGLE)
    push_start, push_passing = graph_push[1], graph_push[2]
    actual = min((t for t in passings if t > push_start), default=math.inf)
    assert push_passing == pytest.approx(actual, abs=0.8), (push_passing, passings)
    assert runner_push[2] == pytest.approx(actual, abs=0.8), (runner_moves, passings)


def _settled_free_motion_errors(bag: Path, hold: float) -> np.ndarray:
    """|x_d - x_R| at the replica's pose stamps with no F/T sample of |F| >= 1 N in the ``hold`` seconds before: the
    report's free motion (fic_teleop_tools.report.metrics.free_motion_flags) with a longer hold."""
    from mcap_ros2.reader import read_ros2_messages

    from fic_teleop_tools.report.metrics import free_motion_flags

    mcap_file = str(next(bag.glob("*.mcap")))
    series: dict[str, dict[int, np.ndarray]] = {}
    for topic in ("/replica/desired_pose", "/replica/tcp_pose", "/ft_sensor/wrench"):
        series[topic] = {}
        for message in read_ros2_messages(mcap_file, topics=[topic]):
            stamp, ros = message.ros_msg.header.stamp, message.ros_msg
            value = ros.wrench.force if topic == "/ft_sensor/wrench" else ros.pose.position
            series[topic][stamp.sec * 1_000_000_000 + stamp.nanosec] = np.array([value.x, value.y, value.z])
    force_ns = np.array(sorted(series["/ft_sensor/wrench"]))
    force = np.array([np.linalg.norm(series["/ft_sensor/wrench"][ns]) for ns in force_ns])
    free = free_motion_flags(force_ns * 1e-9, force, 1.0, hold)
    common = sorted(set(series["/replica/desired_pose"]) & set(series["/replica/tcp_pose"]))
    latest = np.searchsorted(force_ns, common, side="right") - 1
    return np.array([np.linalg.norm(series["/replica/desired_pose"][ns] - series["/replica/tcp_pose"][ns])
                     for ns, index in zip(common, latest) if index >= 0 and free[index]])


def test_the_closed_loop_run_is_safe_and_tracks(closed_loop_run: Path) -> None:
    metrics = json.loads((closed_loop_run / "report" / "metrics.json").read_text())
    assert metrics["limit_violations"] == 0
    assert metrics["dropped_joint_states"] == 0
    # The FIC saturates its force beyond x_b = 50 mm: an RMS within x_b; more would be a loop that lost the target.
    # Sixteen 8-8.5 s lockstep runs (2026-12-05): free-motion RMS 18-33 mm.
    assert metrics["free_motion_error_rms_m"] < 0.05
    # The report's free-motion maximum (free 0.2 s after |F| < 1 N) was 53-96 mm in those runs, every time at
    # 3.5-4.1 s: the arm let go from the fixed obstacle, which it is held at on the first lap ("Operators"), its
    # error still falling from 0.14-0.16 m. Held instead once free for 1 s: 27-62 mm in the sixteen runs, within
    # 80 mm; an arm that does not come back to the target within a second of free motion fails.
    settled = _settled_free_motion_errors(closed_loop_run / "bag", hold=1.0)
    assert settled.size > 100 and settled.max() < 0.08, (settled.size, settled.max(initial=0.0))   # 263-425 samples


