"""The LeRobot export's parts without LeRobot: frame sampling (no frame holds a future value), the episode
markers, the files of the v3.0 layout, and bad input refused in one line. test_dataset_lerobot_load.py loads a
real run's export with LeRobot's own dataset class."""
from __future__ import annotations

import json

import av
import numpy as np
import pyarrow.parquet as pq
import pytest
from dataset_runs import START_NS, stamp_seconds, write_run

from fic_teleop_runtime.episode_markers import MarkerError, outcome
from fic_teleop_tools.cli.__main__ import main as fic
from fic_teleop_tools.dataset.frame_sampling import SamplingError, common_span, frame_times, held_indices

SIZE = "64x48"   # the camera small: these tests check the layout, not the picture


def test_each_frame_holds_the_newest_sample_at_or_before_its_own_time() -> None:
    rng = np.random.default_rng(4)
    samples = np.cumsum(rng.integers(1, 9_000_000, 400)).astype(np.int64)
    frames = frame_times(int(samples[0]), int(samples[-1]), 30)
    held = held_indices(samples, frames)
    assert np.all(samples[held] <= frames)                          # never a future sample
    later = np.minimum(held + 1, len(samples) - 1)
    assert np.all((samples[later] > frames) | (held == len(samples) - 1))   # and the newest one
    exact = held_indices(samples, samples[5:6])                      # a sample stamped at the frame's time is held
    assert exact[0] == 5


def test_frame_times_are_frame_over_fps_to_the_nanosecond() -> None:
    times = frame_times(1_000_000_000, 2_000_000_000, 30)
    assert len(times) == 31 and times[1] - times[0] == 33_333_333 and times[2] - times[0] == 66_666_667
    assert times[-1] == 2_000_000_000


def test_a_frame_before_a_streams_first_sample_and_streams_that_never_overlap_are_refused() -> None:
    with pytest.raises(SamplingError, match="before its first sample"):
        held_indices(np.array([10, 20]), np.array([5, 15]))
    assert common_span({"a": np.array([0, 50]), "b": np.array([10, 80])}) == (10, 50)
    with pytest.raises(SamplingError, match="never overlap"):
        common_span({"a": np.array([0, 5]), "b": np.array([10, 80])})


def test_the_last_keep_or_discard_and_the_last_success_or_failure_decide_and_a_typo_is_refused() -> None:
    unmarked = outcome([])
    assert unmarked.keep and unmarked.success is None
    episode = outcome(["success", "discard", "failure", "Keep"])
    assert episode.keep and episode.success is False and episode.marks == 4
    assert not outcome(["keep", "discard"]).keep
    with pytest.raises(MarkerError, match="one of keep, discard, success, failure"):
        outcome(["sucess"])


def _export(capsys, *arguments: str) -> tuple[int, str, str]:
    code = fic(["dataset", "export", *arguments])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_an_export_writes_the_v3_layout_with_held_values_markers_and_a_frame_a_timestamp(tmp_path, capsys) -> None:
    kept = write_run(tmp_path / "kept", marks=("success",))
    dropped = write_run(tmp_path / "dropped", marks=("keep", "discard"))
    unmarked = write_run(tmp_path / "unmarked", duration_s=0.5)
    out = tmp_path / "dataset"
    code, stdout, stderr = _export(capsys, str(kept), str(dropped), str(unmarked), "--out", str(out), "--size", SIZE)
    assert code == 0, stderr
    assert "dropped: discarded by its episode marker, left out" in stdout

    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["fps"] == 30
    assert info["total_episodes"] == 2 and info["total_tasks"] == 1
    assert info["data_path"] == "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    assert info["video_path"] == "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
    assert info["features"]["observation.state"]["shape"] == [21]
    assert info["features"]["observation.images.scene"]["shape"] == [48, 64, 3]

    data = pq.read_table(out / "data" / "chunk-000" / "file-000.parquet")
    assert info["total_frames"] == data.num_rows
    assert json.loads(data.schema.metadata[b"huggingface"])["info"]["features"]["action"] == {
        "feature": {"dtype": "float32", "_type": "Value"}, "length": 7, "_type": "List"}
    episodes = pq.read_table(out / "meta" / "episodes" / "chunk-000" / "file-000.parquet").to_pylist()
    assert [e["run"] for e in episodes] == ["kept", "unmarked"]
    assert [e["success"] for e in episodes] == [True, None]
    rows = data.to_pylist()
    for episode in episodes:
        frames = rows[episode["dataset_from_index"]:episode["dataset_to_index"]]
        assert len(frames) == episode["length"]
        start = round(episode["start_time"] * 1e9)
        for k, frame in enumerate(frames):
            assert frame["frame_index"] == k and frame["episode_index"] == episode["episode_index"]
            assert frame["timestamp"] == pytest.approx(k / 30, abs=1e-6)
            frame_time = stamp_seconds(start + round(k * 1e9 / 30))
            # each value carries its sample's stamp: held, never from after the frame, and at most a period old
            for key, column, period in (("observation.state", 7, 0.002), ("observation.state", 14, 0.010),
                                        ("observation.wrench", 0, 0.004), ("observation.handle.pose", 0, 0.004),
                                        ("observation.handle.wrench", 5, 0.004), ("action", 2, 0.010)):
                assert frame_time - period - 1e-6 <= frame[key][column] <= frame_time + 1e-6, (key, k)
        assert episode["videos/observation.images.scene/from_timestamp"] == pytest.approx(
            episodes[0]["length"] / 30 if episode["episode_index"] else 0.0)
    assert episodes[0]["start_time"] == pytest.approx(START_NS * 1e-9 + 0.007)  # the latest first sample (x_d)
    with av.open(str(out / "videos" / "observation.images.scene" / "chunk-000" / "file-000.mp4")) as video:
        times = [frame.time for frame in video.decode(video=0)]
    assert times == pytest.approx([k / 30 for k in range(data.num_rows)], abs=1e-6)
    stats = json.loads((out / "meta" / "stats.json").read_text())
    assert np.shape(stats["observation.images.scene"]["mean"]) == (3, 1, 1)
    camera = stats["observation.images.scene"]
    assert 0.0 < np.min(camera["mean"]) < np.max(camera["max"]) <= 1.0
    assert stats["frame_index"]["count"] == [data.num_rows] and len(stats["observation.state"]["q50"]) == 21
    tasks = pq.read_table(out / "meta" / "tasks.parquet")
    assert tasks.column("__index_level_0__").to_pylist() == ["push the box"]
    assert json.loads(tasks.schema.metadata[b"pandas"])["index_columns"] == ["__index_level_0__"]


@pytest.mark.parametrize("case, words", [
    ("torn", "the bag is torn"),
    ("no camera", "no camera: the bag has no /sim/object_poses"),
    ("mixed fps", "mixed fps: the runs' cameras were recorded at 30 Hz (a), 50 Hz (b)"),
    ("fast fps", "--fps 60 is above the camera's recorded rate of a (30 Hz)"),
    ("all discarded", "every run was discarded"),
    ("out not empty", "exists and is not an empty folder"),
    ("no run", "no such run folder"),
])
def test_bad_input_is_refused_in_one_line_and_writes_nothing(tmp_path, capsys, case, words) -> None:
    out = tmp_path / "dataset"
    extra = []
    runs = [write_run(tmp_path / "a", finish=case != "torn", camera=case != "no camera",
                      marks=("discard",) if case == "all discarded" else ())]
    if case == "mixed fps":
        runs.append(write_run(tmp_path / "b", camera_hz=50.0))
    if case == "fast fps":
        extra = ["--fps", "60"]
    if case == "out not empty":
        out.mkdir()
        (out / "something").write_text("x")
    if case == "no run":
        runs = [tmp_path / "missing"]
    code, stdout, stderr = _export(capsys, *map(str, runs), "--out", str(out), "--size", SIZE, *extra)
    assert code == 1
    line, = stderr.strip().splitlines()
    assert line.startswith("fic dataset export: ") and words in line
    assert not out.exists() or case == "out not empty"


def test_a_marker_word_that_is_not_one_is_refused_before_anything_is_published(capsys) -> None:
    assert fic(["episode", "mark", "sucess"]) == 1
    line, = capsys.readouterr().err.strip().splitlines()
    assert line == "fic episode mark: unknown episode marker 'sucess': one of keep, discard, success, failure"
