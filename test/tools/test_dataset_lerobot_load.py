"""A real run's export, loaded with LeRobot's own dataset class (LeRobotDataset of lerobot-dataset 0.4.4, in the
test-only .venv-lerobot that scripts/test.sh builds), checked frame by frame against the bag read with another
library (rosbags): the features, each frame's values held as of its own time, the timestamps, the task, the
operator's marker, and the camera decoded at every timestamp asked of it.

The run, test/data/e1_lockstep_4s: 4 s of the default E1 run in lockstep (`scripts/run_teleop.sh --time-mode
lockstep --duration 4 --task "push the box"`), marked `scripts/fic episode mark success` while it ran; its bag
cut to the topics the export reads and the marker (1 MB).
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import REPO

from fic_teleop_tools.cli.__main__ import main as fic

RUN = REPO / "test" / "data" / "e1_lockstep_4s"
LEROBOT_PYTHON = Path(os.environ.get("FIC_LEROBOT_VENV", REPO / ".venv-lerobot")) / "bin" / "python"
PROBE = REPO / "test" / "tools" / "lerobot_load_probe.py"
FPS = 50   # the run's /sim/object_poses rate (the robot's default object_pose_rate_hz)



@pytest.fixture(autouse=True)
def _lerobot_loader():
    """Skipped when a developer runs pytest without the loader; under scripts/test.sh (FIC_LEROBOT_REQUIRED) a missing
    loader is a failure, so a CI whose setup could not install it does not pass by skipping."""
    if not LEROBOT_PYTHON.exists():
        reason = "LeRobot's loader is not installed: scripts/setup_lerobot_env.sh (scripts/test.sh runs it)"
        if os.environ.get("FIC_LEROBOT_REQUIRED"):
            pytest.fail(reason)
        pytest.skip(reason)


def _bag_streams(bag: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """topic -> (header stamps [ns], values), read with rosbags, not with the export's reader."""
    from rosbags.highlevel import AnyReader

    def pose(p):
        return [p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y, p.orientation.z,
                p.orientation.w]

    def wrench(w):
        return [w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z]

    rows: dict[str, list] = {}
    with AnyReader([bag]) as reader:
        for connection, _, raw in reader.messages():
            message = reader.deserialize(raw, connection.msgtype)
            if connection.topic == "/episode/marker":
                continue
            stamp = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
            if connection.topic == "/joint_states":
                value = list(message.position) + list(message.velocity)
            elif connection.topic == "/sim/object_poses":
                value = [x for p in message.poses for x in pose(p)]
            elif connection.msgtype.endswith("PoseStamped"):
                value = pose(message.pose)
            else:
                value = wrench(message.wrench)
            rows.setdefault(connection.topic, []).append((stamp, value))
    streams = {}
    for topic, samples in rows.items():
        samples.sort(key=lambda sample: sample[0])
        streams[topic] = (np.array([s for s, _ in samples], dtype=np.int64), np.array([v for _, v in samples]))
    return streams


def _held(stream: tuple[np.ndarray, np.ndarray], time_ns: int) -> np.ndarray:
    """The newest sample stamped at or before ``time_ns``, by brute force."""
    stamps, values = stream
    return values[np.flatnonzero(stamps <= time_ns)[-1]]


def test_lerobot_loads_a_real_runs_export_frame_for_frame_as_the_bag_has_it(tmp_path, capsys) -> None:
    runs = [tmp_path / "e1_a", tmp_path / "e1_b"]   # two episodes: the second starts inside the same video file
    for run in runs:
        shutil.copytree(RUN, run)
    out = tmp_path / "dataset"
    assert fic(["dataset", "export", *map(str, runs), "--out", str(out), "--size", "160x120"]) == 0, \
        capsys.readouterr().err
    info = json.loads((out / "meta" / "info.json").read_text())
    length = info["total_frames"] // 2
    indices = [0, 1, length // 2, length - 1, length, info["total_frames"] - 1]
    environment = {**os.environ, "HF_HUB_OFFLINE": "1", "HF_HOME": str(tmp_path / "hf")}
    probe = subprocess.run([str(LEROBOT_PYTHON), str(PROBE), str(out), *map(str, indices)], capture_output=True,
                           text=True, timeout=300, env=environment)
    assert probe.returncode == 0, probe.stderr[-3000:]
    loaded = json.loads(probe.stdout)

    assert loaded["codebase_version"] == "v3.0" and loaded["fps"] == FPS
    assert loaded["schema_as_lerobot_writes_it"]
    assert loaded["num_episodes"] == 2 and loaded["length"] == loaded["num_frames"] == info["total_frames"]
    assert set(loaded["features"]) >= {"observation.state", "observation.wrench", "observation.handle.pose",
                                       "observation.handle.wrench", "action", "observation.images.scene"}
    assert loaded["camera_keys"] == ["observation.images.scene"] and "observation.images.scene" in loaded["stats_keys"]
    assert loaded["tasks"] == ["push the box"]
    assert [episode["success"] for episode in loaded["episodes"]] == [True, True]   # the marker made during the run

    streams = _bag_streams(RUN / "bag")
    start_ns = max(int(stamps[0]) for stamps, _ in streams.values())    # every stream has a sample from here on
    assert loaded["episodes"][0]["start_time"] == pytest.approx(start_ns * 1e-9, abs=1e-9)
    end_ns = min(int(stamps[-1]) for stamps, _ in streams.values())
    assert length == (end_ns - start_ns) * FPS // 1_000_000_000 + 1
    for item in loaded["items"]:
        k = item["frame_index"]
        assert item["index"] == item["episode_index"] * length + k
        assert item["timestamp"] == pytest.approx(k / FPS, abs=1e-5)
        assert item["task"] == "push the box"
        time_ns = start_ns + round(k * 1e9 / FPS)
        expected = {
            "observation.state": np.concatenate([_held(streams["/joint_states"], time_ns),
                                                 _held(streams["/replica/tcp_pose"], time_ns)]),
            "observation.wrench": _held(streams["/ft_sensor/wrench"], time_ns),
            "observation.handle.pose": _held(streams["/haptic/pose"], time_ns),
            "observation.handle.wrench": _held(streams["/haptic/wrench_command"], time_ns),
            "action": _held(streams["/replica/desired_pose"], time_ns),
        }
        for key, value in expected.items():
            np.testing.assert_allclose(item[key], value.astype(np.float32), rtol=1e-6, atol=1e-6, err_msg=key)
        assert item["image_shape"] == [3, 120, 160]
        assert 0.0 <= item["image_min"] < 0.2 < item["image_mean"] < 0.8 < item["image_max"] <= 1.0
