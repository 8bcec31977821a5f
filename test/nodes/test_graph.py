"""The whole graph, as the main job starts it: real processes over DDS, the MuJoCo Panda, the channel, the recorder
and the report. One short lockstep run with a blackout window in the channel is checked end to end; a second run
is interrupted with Ctrl-C and must still leave a finished bag and a report."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import (
    REPO,
    NodeProcess,
    assert_stopped_clean,
    installed_executable,
    isolated_env,
    recorded_so_far,
    reserved_domain,
    unclean_exit,
)

LAUNCHER = REPO / "scripts" / "teleop_launcher.py"
pytestmark = pytest.mark.nodes

BLACKOUT = (3.0, 5.0)  # [s] after the channels start: both directions lose everything


def _launch(ros_env: dict[str, str], out: Path, *arguments: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, str(LAUNCHER), "--out", str(out), *arguments], env=ros_env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)


@pytest.fixture(scope="module")
def blackout_run(tmp_path_factory) -> Path:
    """A 10 s lockstep run of the superimposition scene with 200 ms delay and a 2 s blackout in the channel."""
    out = tmp_path_factory.mktemp("graph") / "run"
    with reserved_domain() as domain:
        env = isolated_env(out.parent / "ros_log", domain)
        process = _launch(env, out, "--duration", "10", "--time-mode", "lockstep", "--delay", "0.2",
                          "--blackout-window", str(BLACKOUT[0]), str(BLACKOUT[1]), "--no-video",
                          "--wall-limit", "400")
        output, _ = process.communicate(timeout=600)
    (out / "launcher_output.txt").write_text(output)
    assert_run_stopped_clean(process.returncode, output, out)
    return out


def assert_run_stopped_clean(returncode: int | None, output: str, out: Path) -> None:
    """The launcher exited 0 and every node of the graph stopped clean (no traceback, no FATAL line)."""
    assert_stopped_clean(returncode, output, "the launcher")
    logs = sorted((out / "logs").glob("*.log"))
    assert logs, f"no node logs in {out / 'logs'}"
    for log in logs:
        text = log.read_text(errors="replace")
        problem = unclean_exit(0, text)
        assert not problem, f"{log.name}: {problem}\n{text[-2000:]}"


def test_metrics_of_the_run_show_the_channel_delay_and_no_limit_violation(blackout_run: Path) -> None:
    metrics = json.loads((blackout_run / "report" / "metrics.json").read_text())
    assert metrics["controller"] == "fic"
    assert metrics["delay_one_way_ms"] == pytest.approx(200.0, abs=5.0)  # the channel's set point, end to end
    assert metrics["limit_violations"] == 0
    assert metrics["dropped_joint_states"] == 0  # lockstep stamps are on the 1 ms grid: every state recorded
    assert metrics["duration_s"] >= 8.5


def test_bag_reads_back_with_independent_readers(blackout_run: Path) -> None:
    from mcap_ros2.reader import read_ros2_messages
    from rosbags.highlevel import AnyReader

    expected = {
        "/joint_states": "sensor_msgs/msg/JointState",
        "/effort_controller/commands": "std_msgs/msg/Float64MultiArray",
        "/replica/teleop_command": "fic_teleop_msgs/msg/TeleoperationCommand",
        "/replica/fic_state": "fic_teleop_msgs/msg/FicState",
        "/replica/limit_status": "fic_teleop_msgs/msg/LimitStatus",
        "/haptic/pose": "geometry_msgs/msg/PoseStamped",
        "/master/feedback_wrench": "geometry_msgs/msg/WrenchStamped",
        "/channel/deliveries": "fic_teleop_msgs/msg/ChannelDelivery",
    }
    bag = blackout_run / "bag"
    with AnyReader([bag]) as reader:
        types = {connection.topic: connection.msgtype for connection in reader.connections}
        for topic, message_type in expected.items():
            assert types.get(topic) == message_type, f"{topic}: {types.get(topic)}"
        joint_states = [c for c in reader.connections if c.topic == "/joint_states"]
        count = sum(1 for _ in reader.messages(connections=joint_states))
    mcap_file = next(bag.glob("*.mcap"))
    decoded = sum(1 for _ in read_ros2_messages(str(mcap_file), topics=["/joint_states"]))
    assert decoded == count >= 9000  # 1 kHz for the whole 9 s run from t = 0, the same count by both readers


def test_blackout_leaves_the_replica_stable_and_it_recovers(blackout_run: Path) -> None:
    from mcap_ros2.reader import read_ros2_messages

    mcap_file = str(next((blackout_run / "bag").glob("*.mcap")))
    deliveries = [m.ros_msg for m in read_ros2_messages(mcap_file, topics=["/channel/deliveries"])]
    received = np.array([d.received.sec + 1e-9 * d.received.nanosec for d in deliveries])
    start = received.min() - 0.5  # deliveries start within the first second of the channels' time
    in_blackout = [(t - start) for t in received if BLACKOUT[0] + 0.3 < t - start < BLACKOUT[1] - 0.3]
    assert not in_blackout, "the channel delivered during its blackout"
    assert np.any(received - start > BLACKOUT[1] + 0.5), "no delivery after the blackout: no recovery"

    states = [m.ros_msg for m in read_ros2_messages(mcap_file, topics=["/replica/fic_state"])]
    stale = np.array([s.master_stale for s in states])
    assert stale.any(), "the replica never noticed the lost master"
    first_stale = int(np.argmax(stale))
    # (the very last states may be stale again: the launcher stops the master before the replica)
    assert not stale[first_stale:].all(), "the replica did not resume when the master came back"
    # Physics of the run (lockstep runs under a load average of 30 on 2 cores, 2026-12-02; the second with the
    # passive attractor and F_max = 10 N: |x_d - x_R| at most 21 / 38 mm and energy at most 0.32 / 0.29 J outside
    # the blackout and the 2 s after it (a 9 s run), RMS 12 / 12.5 mm; the resume after the blackout peaks at 89 / 97 mm
    # and 1.10 / 0.96 J). Bounds: x_b = 50 mm, the FIC's own saturation error, outside the loss and its recovery; RMS
    # 25 mm (about 2x); energy 0.6 J there and 2 J over the run (about 2x).
    # The loss and its recovery are the replica's own: from its first stale state to 3 s after it resumed (the
    # channel's clock origin is only known to within its first delivery). The catch-up takes longer than 2 s: two
    # quiet runs (15:20) still had 31 / 47 mm 2.0-2.5 s after the resume, and one fresh-clone suite 56 mm; from 3 s
    # on, 25 mm at most, as before the loss (17-28 mm). But the E1 operator's avoid and push moves, not the loss,
    # set the largest free-motion error of a lockstep run: 40-55 mm in five quiet 12 s runs without any loss
    # (docs/HARDWARE.md, 2026-12-04), and a loaded suite's run here had 53 mm at 9.5 s, in the push move of the
    # third lap, 3.8 s after the resume; the peer barrier lets the operator's side trail the physics by up to
    # 30 ms, which moves that peak with the load. So: 2 x_b outside the loss and its recovery, as for the other
    # E1 graph runs (a loop that lost its target leaves it), and the RMS over the whole run within 25 mm.
    times = np.array([s.header.stamp.sec + 1e-9 * s.header.stamp.nanosec for s in states]) - start
    errors = np.array([np.linalg.norm(s.error[:3]) for s in states])
    energy = np.array([s.total_energy for s in states])
    resumed = first_stale + int(np.argmin(stale[first_stale:]))
    settled = (times < times[first_stale]) | (times > times[resumed] + 3.0)
    assert settled.sum() > 0.4 * len(states)  # (measured 56 %)
    assert errors[settled].max() < 0.1, errors[settled].max()
    assert float(np.sqrt(np.mean(errors ** 2))) < 0.025
    assert np.all(np.isfinite(energy)) and energy.max() < 2.0, energy.max()
    assert energy[settled].max() < 0.6, energy[settled].max()
    log = (blackout_run / "logs" / "replica.log").read_text()
    assert log.count("no teleoperation command for more than") >= 1
    assert "teleoperation commands are back" in log


#: Messages on the bag's flushed chunks before the Ctrl-C (the finished bag must then hold more).
INTERRUPT_AFTER_MESSAGES = 2000


def test_ctrl_c_still_finishes_the_bag_and_the_report(tmp_path: Path, ros_env: dict[str, str]) -> None:
    from mcap.reader import make_reader

    out = tmp_path / "run"
    process = _launch(ros_env, out, "--duration", "60", "--time-mode", "lockstep", "--no-video")
    deadline = time.monotonic() + 240
    while recorded_so_far(out / "bag") < INTERRUPT_AFTER_MESSAGES:  # the graph is really running and recording
        assert time.monotonic() < deadline and process.poll() is None, "the run never recorded enough to interrupt"
        time.sleep(0.5)
    process.send_signal(signal.SIGINT)
    output, _ = process.communicate(timeout=300)
    assert "interrupted" in output, output
    mcap_file = next((out / "bag").glob("*.mcap"))
    with open(mcap_file, "rb") as stream:
        summary = make_reader(stream).get_summary()  # a finished bag has its summary and footer
    assert summary is not None and summary.statistics.message_count >= INTERRUPT_AFTER_MESSAGES
    assert (out / "report" / "metrics.json").exists()


#: Metrics of a replayed bag that are not the run's but the replay's: wall time, the pace of the replay, and what
#: the report counts of /diagnostics (its publishers were not replayed at their own rate).
REPLAY_DEPENDENT = ("real_time_factor", "wall_duration_s", "bag")


def _replay_rate(metrics: dict) -> float:
    """1 / the run's real-time factor (a lockstep run is slower than real time), never below 1."""
    factor = metrics.get("real_time_factor")
    return max(1.0, 1.0 / factor) if isinstance(factor, float) and factor > 0.0 else 1.0


def test_bag_played_into_the_recorder_gives_the_report_the_same_metrics(blackout_run: Path, tmp_path: Path) -> None:
    """`scripts/fic bag play` puts the recorded bag back on the topics, the project's recorder records it again,
    and the report of the second bag gives the run's metrics: every message came through, contents unchanged."""
    original = json.loads((blackout_run / "report" / "metrics.json").read_text())
    replayed_bag = tmp_path / "replayed"
    with reserved_domain() as domain:
        env = isolated_env(tmp_path / "ros_log", domain)
        recorder = NodeProcess(
            [str(installed_executable("fic_teleop_tools", "recorder_node")), "--ros-args",
             "-r", "__node:=recorder", "-p", f"bag_path:={replayed_bag}", "-p", "all:=true",
             "-p", "discovery_period:=0.1"], env, tmp_path / "recorder.log")
        try:
            # The recorder subscribes as publishers appear; play waits for a reader on each topic, and at the end
            # for every reliable reader's acknowledgement of what it was sent.
            assert recorder.wait_for_output("recording to", timeout=120), recorder.output()
            # At the pace of simulated time: the bag's receive times are the lockstep run's, stretched by its
            # real-time factor (0.27 in one run at load 4), so a replay at 1 / RTF carries the message rates of a
            # realtime run, which the recorder takes whole; every message must still come through.
            play = subprocess.run([str(REPO / "scripts" / "fic"), "bag", "play", str(blackout_run / "bag"),
                                   "--wait-for-subscribers", "30", "--rate", f"{_replay_rate(original):.3f}"],
                                  env=env, capture_output=True, text=True, timeout=300)
            assert play.returncode == 0, play.stdout + play.stderr
            assert "not acknowledged" not in play.stderr, play.stderr
        finally:
            returncode = recorder.stop(timeout=60)
    assert_stopped_clean(returncode, recorder.output(), "recorder")
    out = tmp_path / "report"
    result = subprocess.run([sys.executable, "-m", "fic_teleop_tools.report", str(replayed_bag), "--out", str(out)],
                            env=env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    replayed = json.loads((out / "metrics.json").read_text())
    differing = {}
    counts, replayed_counts = original.pop("message_counts"), replayed.pop("message_counts")
    for topic, count in counts.items():
        if topic not in ("/diagnostics", "/rosout", "/parameter_events") and replayed_counts.get(topic) != count:
            differing[f"message_counts[{topic}]"] = (count, replayed_counts.get(topic))
    for key, value in original.items():
        if key in REPLAY_DEPENDENT or "diagnostic" in key:
            continue
        if key == "targets":   # whether each figure met its target: those of the replay's own figures are its own
            value = {name: target for name, target in value.items() if name not in REPLAY_DEPENDENT}
            replayed[key] = {name: target for name, target in replayed.get(key, {}).items()
                             if name not in REPLAY_DEPENDENT}
        other = replayed.get(key)
        same = (other == pytest.approx(value, rel=1e-6, abs=1e-9)) if isinstance(value, float) else other == value
        if not same:
            differing[key] = (value, other)
    assert not differing, "\n".join(f"{key}: {pair[0]} against {pair[1]}" for key, pair in differing.items())
