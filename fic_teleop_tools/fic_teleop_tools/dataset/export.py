"""Runs to a LeRobot v3.0 dataset: one episode a run (``scripts/fic dataset export RUN_DIR... --out DIR``).

Each kept run becomes an episode: frames at the dataset's fps over the span every stream covers, each frame holding
every stream's newest sample at or before its time (frame_sampling.py), and the scene's camera rendered after the
run at the same times (scene_camera.py). A run its markers discard is left out and said so; the last
success/failure marker is the episode's ``success`` (fic_teleop_runtime.episode_markers).

The features (docs/TOOLS.md, "Datasets", says why each and why the action is the set-point):

- ``observation.state``: the arm's joint positions and velocities (/joint_states) and the TCP pose x_R
  (/replica/tcp_pose: position, quaternion x y z w);
- ``observation.wrench``: the wrist force/torque sensor's wrench, the environment on the TCP (/ft_sensor/wrench);
- ``observation.handle.pose``: the haptic handle's displacement x_M and orientation (/haptic/pose);
- ``observation.handle.wrench``: the wrench rendered at the handle, what the operator's hand felt: the master's
  f = FIC(-x_M) + K_H F_R (paper Eq. 3; /haptic/wrench_command);
- ``action``: the replica's set-point x_d = x_d' + x_d'' (/replica/desired_pose), position and quaternion;
- ``observation.images.scene``: the scene's camera.

The dataset's fps is the rate the camera's source (/sim/object_poses) was recorded at, the same for every run
(mixed rates are refused: a LeRobot dataset has one fps), or ``--fps`` when it is not above any run's.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from fic_teleop_tools.dataset import lerobot_layout as layout
from fic_teleop_tools.dataset.frame_sampling import (
    SamplingError,
    common_span,
    frame_times,
    held_indices,
    stream_rate_hz,
)
from fic_teleop_tools.dataset.run_recording import (
    HANDLE_POSE,
    HANDLE_WRENCH,
    JOINT_STATES,
    OBJECT_POSES,
    SET_POINT,
    STREAMS,
    TCP_POSE,
    WRIST_WRENCH,
    RecordingError,
    RunRecording,
    read_run,
)
from fic_teleop_tools.dataset.scene_camera import (
    CODEC_NAME,
    PIX_FMT,
    STATS_STRIDE,
    SceneCamera,
    VideoFile,
    stats_frame_numbers,
)

CAMERA = "observation.images.scene"
ROBOT_TYPE = "panda"
POSE_NAMES = ("x", "y", "z", "qx", "qy", "qz", "qw")
WRENCH_NAMES = ("fx", "fy", "fz", "tx", "ty", "tz")


class DatasetError(ValueError):
    """The export cannot be done; one line that says why."""


@dataclass
class ExportSummary:
    root: Path
    fps: int
    episodes: list[tuple[str, int, bool | None]] = field(default_factory=list)  # run, frames, success
    left_out: list[tuple[str, str]] = field(default_factory=list)               # run, why

    @property
    def frames(self) -> int:
        return sum(frames for _, frames, _ in self.episodes)


def features(joint_names: list[str], fps: int, width: int, height: int) -> dict[str, dict]:
    """The dataset's features, in the order of the data files' columns (LeRobot's bookkeeping columns last)."""
    return {
        "observation.state": layout.vector_feature([f"{name}.pos" for name in joint_names]
                                                   + [f"{name}.vel" for name in joint_names]
                                                   + [f"tcp.{axis}" for axis in POSE_NAMES]),
        "observation.wrench": layout.vector_feature([f"wrist.{axis}" for axis in WRENCH_NAMES]),
        "observation.handle.pose": layout.vector_feature([f"handle.{axis}" for axis in POSE_NAMES]),
        "observation.handle.wrench": layout.vector_feature([f"handle.{axis}" for axis in WRENCH_NAMES]),
        "action": layout.vector_feature([f"set_point.{axis}" for axis in POSE_NAMES]),
        CAMERA: layout.video_feature(height, width, fps, CODEC_NAME, PIX_FMT),
        **layout.INDEX_FEATURES,
    }


def camera_rate(recording: RunRecording) -> int:
    try:
        return round(stream_rate_hz(recording.streams[OBJECT_POSES].stamps))
    except SamplingError as error:
        raise DatasetError(f"{recording.name}: its camera stream {OBJECT_POSES} has no rate ({error})") from None


def dataset_fps(recordings: list[RunRecording], requested: int | None) -> int:
    """The camera's recorded rate, one for all runs; or ``requested``, if no run's camera is slower."""
    rates = {recording.name: camera_rate(recording) for recording in recordings}
    if requested is not None:
        if requested <= 0:
            raise DatasetError(f"--fps must be > 0, got {requested}")
        slower = {name: rate for name, rate in rates.items() if rate < requested}
        if slower:
            raise DatasetError(f"--fps {requested} is above the camera's recorded rate of "
                               + ", ".join(f"{name} ({rate} Hz)" for name, rate in slower.items())
                               + ": its frames would repeat the scene")
        return requested
    if len(set(rates.values())) > 1:
        raise DatasetError("mixed fps: the runs' cameras were recorded at "
                           + ", ".join(f"{rate} Hz ({name})" for name, rate in rates.items())
                           + f"; a dataset has one fps: give --fps {min(rates.values())} or export them apart")
    return next(iter(rates.values()))


@dataclass
class EpisodeFrames:
    """One episode sampled at the dataset's frame times: a column per feature, the camera's inputs."""
    start_ns: int
    columns: dict[str, np.ndarray]
    joint_positions: np.ndarray
    body_poses: np.ndarray

    def __len__(self) -> int:
        return len(self.joint_positions)


def sample_episode(recording: RunRecording, fps: int) -> EpisodeFrames:
    """Every stream held at each frame time (no frame holds a sample stamped after it)."""
    streams = recording.streams
    try:
        start_ns, end_ns = common_span({topic: streams[topic].stamps for topic in STREAMS})
        times = frame_times(start_ns, end_ns, fps)
        held = {topic: streams[topic].values[held_indices(streams[topic].stamps, times, topic)] for topic in STREAMS}
    except SamplingError as error:
        raise DatasetError(f"{recording.name}: {error}") from None
    joints = len(recording.joint_names)
    columns = {
        "observation.state": np.hstack([held[JOINT_STATES][:, :2 * joints], held[TCP_POSE]]),
        "observation.wrench": held[WRIST_WRENCH],
        "observation.handle.pose": held[HANDLE_POSE],
        "observation.handle.wrench": held[HANDLE_WRENCH],
        "action": held[SET_POINT],
    }
    return EpisodeFrames(start_ns, columns, held[JOINT_STATES][:, :joints], held[OBJECT_POSES])


def _check_out(out: Path) -> None:
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise DatasetError(f"--out {out} exists and is not an empty folder; give a new one")


def _read_all(runs: list[Path], task: str | None, scene: str | None) -> list[RunRecording]:
    recordings = []
    for run in runs:
        try:
            recordings.append(read_run(run, task=task, scene=scene))
        except RecordingError as error:
            raise DatasetError(str(error)) from None
    return recordings


def export(runs: list[str | Path], out: str | Path, fps: int | None = None, task: str | None = None,
           scene: str | None = None, width: int = 640, height: int = 480,
           say: Callable[[str], None] = print) -> ExportSummary:
    """Export ``runs`` (run folders, or bag folders with ``scene``) as a LeRobot v3.0 dataset at ``out``."""
    out = Path(out)
    _check_out(out)
    if width <= 0 or height <= 0 or width % 2 or height % 2:
        raise DatasetError(f"--size {width}x{height}: even, positive width and height needed (yuv420p video)")
    recordings = _read_all([Path(run) for run in runs], task, scene)
    names = {tuple(recording.joint_names) for recording in recordings}
    if len(names) > 1:
        raise DatasetError(f"the runs' arms differ (joint names {sorted(names)}): one dataset has one state layout")
    rate = dataset_fps(recordings, fps)
    summary = ExportSummary(out, rate)
    kept = []
    for recording in recordings:
        if recording.outcome.keep:
            kept.append(recording)
        else:
            summary.left_out.append((recording.name, "discarded by its episode marker"))
            say(f"[dataset] {recording.name}: discarded by its episode marker, left out")
    if not kept:
        raise DatasetError("every run was discarded by its episode markers: nothing to export")
    spec = features(kept[0].joint_names, rate, width, height)
    sampled = [sample_episode(recording, rate) for recording in kept]   # every run checked before a file is written
    out.mkdir(parents=True, exist_ok=True)
    try:
        _write(out, spec, rate, kept, sampled, width, height, summary, say)
    except BaseException:
        import shutil
        shutil.rmtree(out, ignore_errors=True)  # a half-written dataset is worse than none
        raise
    return summary


def _write(out: Path, spec: dict[str, dict], fps: int, kept: list[RunRecording], sampled: list[EpisodeFrames],
           width: int, height: int, summary: ExportSummary, say: Callable[[str], None]) -> None:
    tasks: list[str] = []
    rows, all_columns, all_images = [], [], []
    data_cursor, video_cursor = layout.FileCursor(), layout.FileCursor()
    data_writer, data_bytes = None, 0
    video, video_start_frame = None, 0
    cameras: dict[str, SceneCamera] = {}
    index = 0
    try:
        for episode_index, (recording, frames) in enumerate(zip(kept, sampled)):
            if recording.task not in tasks:
                tasks.append(recording.task)
            length = len(frames)
            columns = dict(frames.columns)
            frame_index = np.arange(length, dtype=np.int64)
            columns.update(timestamp=(frame_index / fps).astype(np.float32), frame_index=frame_index,
                           episode_index=np.full(length, episode_index, dtype=np.int64),
                           index=index + frame_index, task_index=np.full(length, tasks.index(recording.task),
                                                                         dtype=np.int64))
            table = layout.frame_table(spec, columns)
            if data_writer is not None and data_bytes >= layout.DATA_FILES_SIZE_IN_MB * 2**20:
                data_writer.close()
                data_writer, data_bytes = None, 0
                data_cursor.advance()
            if data_writer is None:
                path = out / data_cursor.path(layout.DATA_PATH)
                path.parent.mkdir(parents=True, exist_ok=True)
                data_writer = pq.ParquetWriter(path, table.schema, compression="snappy")
            data_writer.write_table(table)
            data_bytes += table.nbytes

            if video is not None and video.size_in_mb() >= layout.VIDEO_FILES_SIZE_IN_MB:
                video.close()
                video = None
                video_cursor.advance()
            if video is None:
                video = VideoFile(out / video_cursor.path(layout.VIDEO_PATH, video_key=CAMERA), fps, width, height)
                video_start_frame = 0
            camera = cameras.get(recording.scene)
            if camera is None:
                try:
                    camera = cameras[recording.scene] = SceneCamera(
                        recording.scene, recording.joint_names, frames.body_poses.shape[1] // 7, width, height)
                except ValueError as error:
                    raise DatasetError(f"{recording.name}: no camera: {error}") from None
            from_timestamp = (video.frames - video_start_frame) / fps
            sampled_for_stats = stats_frame_numbers(length)
            images = []
            for k in range(length):
                image = camera.render(frames.joint_positions[k], frames.body_poses[k])
                video.add(image)
                if k in sampled_for_stats:
                    images.append(image[::STATS_STRIDE, ::STATS_STRIDE])
            episode_stats = {key: layout.feature_stats(columns[key]) for key in spec if spec[key]["dtype"] != "video"}
            episode_stats[CAMERA] = layout.image_stats(np.stack(images))
            rows.append({
                "episode_index": episode_index,
                "tasks": [recording.task],
                "length": length,
                "data/chunk_index": data_cursor.chunk_index,
                "data/file_index": data_cursor.file_index,
                "dataset_from_index": index,
                "dataset_to_index": index + length,
                f"videos/{CAMERA}/chunk_index": video_cursor.chunk_index,
                f"videos/{CAMERA}/file_index": video_cursor.file_index,
                f"videos/{CAMERA}/from_timestamp": from_timestamp,
                f"videos/{CAMERA}/to_timestamp": from_timestamp + length / fps,
                **layout.flat_stats(episode_stats),
                "meta/episodes/chunk_index": 0,
                "meta/episodes/file_index": 0,
                "success": recording.outcome.success,
                "run": recording.name,
                "scene": recording.scene,
                "start_time": frames.start_ns * 1e-9,
            })
            all_columns.append(columns)
            all_images.extend(images)
            index += length
            summary.episodes.append((recording.name, length, recording.outcome.success))
            outcome = {None: "not marked", True: "success", False: "failure"}[recording.outcome.success]
            say(f"[dataset] episode {episode_index}: {recording.name}, {length} frames ({length / fps:.1f} s), "
                f"{outcome}")
    finally:
        if data_writer is not None:
            data_writer.close()
        if video is not None:
            video.close()
        for camera in cameras.values():
            camera.close()
    layout.write_tasks(tasks, out)
    layout.write_episodes(rows, out, types={"success": pa.bool_()})
    stats = {key: layout.feature_stats(np.concatenate([columns[key] for columns in all_columns]))
             for key in spec if spec[key]["dtype"] != "video"}
    stats[CAMERA] = layout.image_stats(np.stack(all_images))
    layout.write_json(layout.json_stats(stats), out / layout.STATS_PATH)
    layout.write_json(layout.info(spec, fps, len(rows), index, len(tasks), ROBOT_TYPE), out / layout.INFO_PATH)
