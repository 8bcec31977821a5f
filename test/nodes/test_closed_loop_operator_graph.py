"""The closed-loop operator in the DDS graph: the device node watches the replica's video after the backward
channel and times its moves from it, as the in-process runner's operator does (docs/EXPERIMENTS.md, "Operators").

A short lockstep E1 run with ``--operator closed-loop``: the video crosses the channel with the link's delay, the
operator starts its avoid and push moves for the passings it predicts, and those agree with the in-process
runner's operator on the same cell; the run stays inside the arm's limits and tracks within a bound."""
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


def _passing_times(bag: Path, angle: float) -> list[float]:
    """When the replica's TCP (the simulator's /sim/tcp_pose) crossed ``angle`` on the E1 circle [s, sim time]."""
    from mcap_ros2.reader import read_ros2_messages

    stamps, angles = [], []
    for message in read_ros2_messages(str(next(bag.glob("*.mcap"))), topics=["/sim/tcp_pose"]):
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
    from sim_bridge.experiments.in_process import RunConfig, run

    log = (closed_loop_run / "logs" / "haptic_device.log").read_text()
    graph_moves = [(name, float(start), float(passing)) for name, start, passing in MOVE.findall(log)]
    runner_moves = [move for move in run(RunConfig(duration=DURATION_S, operator="closed_loop")).operator_moves
                    if move[1] < DURATION_S - 0.5]   # the graph's last tick may come before the launcher stops it
    # The fixed obstacle first (avoid), then the pushable one (push): what the operator saw decides each.
    assert [move[0] for move in graph_moves][:2] == ["avoid", "push"], graph_moves
    assert [move[0] for move in runner_moves][:2] == ["avoid", "push"], runner_moves
    # The first lap's two moves start when the runner's do: 0-0.28 s apart in three loaded runs (2026-12-04).
    for (_, graph_start, _), (_, runner_start, _) in zip(graph_moves[:2], runner_moves[:2]):
        assert graph_start == pytest.approx(runner_start, abs=0.6)
    # The avoid's passing is predicted before the operator has moved its hand, from the same unperturbed circle as
    # the runner's: 0.08-0.13 s apart in those runs.
    assert graph_moves[0][2] == pytest.approx(runner_moves[0][2], abs=0.3)
    # The push's passing is predicted from frames taken while the avoid moved the arm off the circle, which the
    # operator subtracts with its own hand's history (the efference copy) at the frame's arrival; in lockstep the
    # node's clock at a callback runs ahead of the arrival by its backlog, likely why this estimate moves with the
    # load: the three runs predicted 5.58, 5.37 and 5.21 s, the runner 5.81 s, while the arm passed at 5.51 s in all
    # three (lockstep moves it alike). Held against the passing that happened, within 0.4 s (30 degrees of the
    # 4 s lap); a predicted passing off by a lap or a wrong speed fails.
    passings = _passing_times(closed_loop_run / "bag", PUSHABLE_OBSTACLE_ANGLE)
    push_start, push_passing = graph_moves[1][1], graph_moves[1][2]
    actual = min((t for t in passings if t > push_start), default=math.inf)
    assert push_passing == pytest.approx(actual, abs=0.4), (push_passing, passings)


def test_the_closed_loop_run_is_safe_and_tracks(closed_loop_run: Path) -> None:
    metrics = json.loads((closed_loop_run / "report" / "metrics.json").read_text())
    assert metrics["limit_violations"] == 0
    assert metrics["dropped_joint_states"] == 0
    # One 12 s run (2026-12-02 15:23): 53 mm max, 16 mm RMS in free motion (the scripted E1 run: about 40 / 12 mm);
    # a loaded suite run of 8 s (2026-12-03), whose operator planned a push as well as its avoid moves: 87 / 31.8 mm.
    # The operator's plan follows the video's arrival, which the lockstep barrier does not pace, so it varies with
    # the load. The FIC saturates its force beyond x_b = 50 mm: twice that at most, an RMS within x_b; more would be
    # a loop that lost the target.
    assert metrics["free_motion_error_max_m"] < 0.1
    assert metrics["free_motion_error_rms_m"] < 0.05
