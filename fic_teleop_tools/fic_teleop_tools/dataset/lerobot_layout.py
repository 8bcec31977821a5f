"""The LeRobot dataset format, codebase version v3.0, written with pyarrow (docs/TOOLS.md, "Datasets").

What LeRobot's own reader (``LeRobotDataset`` of lerobot 0.4.x / lerobot-dataset 0.4.4) expects under a root:

- ``meta/info.json``: ``codebase_version`` "v3.0", fps, totals, the path templates, the features (dtype, shape,
  names; a video feature also its ``info``), the splits;
- ``meta/tasks.parquet``: one row a task, the task string as the pandas index, its ``task_index``;
- ``meta/episodes/chunk-000/file-000.parquet``: one row an episode: its index, tasks, length, where its rows and
  its video are (``data/chunk_index``, ``dataset_from_index``, ``videos/<key>/from_timestamp``, ...), its
  statistics as ``stats/<feature>/<stat>`` columns, and our own columns (``success``, ``run``, ...);
- ``meta/stats.json``: the statistics of every feature over the whole dataset (min, max, mean, std, count,
  q01, q10, q50, q90, q99; a camera's per channel, in [0, 1], shape (3, 1, 1));
- ``data/chunk-XXX/file-XXX.parquet``: one row a frame, a column a non-video feature (vectors as fixed-size lists,
  with the Hugging Face ``datasets`` features in the schema's metadata, as LeRobot's writer leaves them);
- ``videos/<key>/chunk-XXX/file-XXX.mp4``: the frames of consecutive episodes, one after the other.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

CODEBASE_VERSION = "v3.0"
CHUNKS_SIZE = 1000              # files a chunk folder holds before the next one
DATA_FILES_SIZE_IN_MB = 100     # a data file is closed past this
VIDEO_FILES_SIZE_IN_MB = 200    # a video file is closed past this
CHUNK_FILE = "chunk-{chunk_index:03d}/file-{file_index:03d}"
DATA_PATH = "data/" + CHUNK_FILE + ".parquet"
VIDEO_PATH = "videos/{video_key}/" + CHUNK_FILE + ".mp4"
EPISODES_PATH = "meta/episodes/" + CHUNK_FILE + ".parquet"
INFO_PATH = "meta/info.json"
STATS_PATH = "meta/stats.json"
TASKS_PATH = "meta/tasks.parquet"
#: Every frame's bookkeeping columns, as LeRobot defines them.
INDEX_FEATURES = {
    "timestamp": {"dtype": "float32", "shape": [1], "names": None},
    "frame_index": {"dtype": "int64", "shape": [1], "names": None},
    "episode_index": {"dtype": "int64", "shape": [1], "names": None},
    "index": {"dtype": "int64", "shape": [1], "names": None},
    "task_index": {"dtype": "int64", "shape": [1], "names": None},
}
QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)


@dataclass
class FileCursor:
    """Where the next episode goes: a chunk folder and a file in it; the next file once this one is full."""
    chunk_index: int = 0
    file_index: int = 0

    def advance(self) -> None:
        self.file_index += 1
        if self.file_index == CHUNKS_SIZE:
            self.chunk_index, self.file_index = self.chunk_index + 1, 0

    def path(self, template: str, **keys: str) -> str:
        return template.format(chunk_index=self.chunk_index, file_index=self.file_index, **keys)


def vector_feature(names: list[str]) -> dict[str, Any]:
    return {"dtype": "float32", "shape": [len(names)], "names": list(names)}


def video_feature(height: int, width: int, fps: int, codec: str, pix_fmt: str) -> dict[str, Any]:
    """A camera stored as video, with the ``info`` LeRobot's writer reads back from the first file."""
    return {"dtype": "video", "shape": [height, width, 3], "names": ["height", "width", "channels"],
            "info": {"video.height": height, "video.width": width, "video.codec": codec, "video.pix_fmt": pix_fmt,
                     "video.is_depth_map": False, "video.fps": fps, "video.channels": 3, "has_audio": False}}


def info(features: dict[str, dict], fps: int, total_episodes: int, total_frames: int, total_tasks: int,
         robot_type: str) -> dict[str, Any]:
    has_video = any(feature["dtype"] == "video" for feature in features.values())
    return {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": robot_type,
        "total_episodes": total_episodes,
        "total_frames": total_frames,
        "total_tasks": total_tasks,
        "chunks_size": CHUNKS_SIZE,
        "data_files_size_in_mb": DATA_FILES_SIZE_IN_MB,
        "video_files_size_in_mb": VIDEO_FILES_SIZE_IN_MB,
        "fps": fps,
        "splits": {"train": f"0:{total_episodes}"},
        "data_path": DATA_PATH,
        "video_path": VIDEO_PATH if has_video else None,
        "features": features,
    }


def write_json(data: dict, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=4, ensure_ascii=False))


def _hf_feature(feature: dict) -> dict:
    """A LeRobot feature as the Hugging Face ``datasets`` library serialises it (a scalar or a fixed-length list)."""
    value = {"dtype": feature["dtype"], "_type": "Value"}
    if list(feature["shape"]) == [1]:
        return value
    return {"feature": value, "length": int(feature["shape"][0]), "_type": "List"}


def _arrow_type(feature: dict) -> pa.DataType:
    scalar = pa.float32() if feature["dtype"] == "float32" else pa.int64()
    return scalar if list(feature["shape"]) == [1] else pa.list_(scalar, int(feature["shape"][0]))


def frame_schema(features: dict[str, dict]) -> pa.Schema:
    """The data files' schema: every non-video feature, with the ``datasets`` features in its metadata."""
    columns = {key: feature for key, feature in features.items() if feature["dtype"] != "video"}
    metadata = {"info": {"features": {key: _hf_feature(feature) for key, feature in columns.items()}}}
    return pa.schema([pa.field(key, _arrow_type(feature)) for key, feature in columns.items()],
                     metadata={b"huggingface": json.dumps(metadata).encode()})


def frame_table(features: dict[str, dict], columns: dict[str, np.ndarray]) -> pa.Table:
    """One episode's frames as a table of ``frame_schema``: ``columns`` maps each feature to an array, one row a
    frame (n x width for a vector)."""
    schema = frame_schema(features)
    arrays = []
    for field_ in schema:
        values = np.asarray(columns[field_.name])
        if pa.types.is_fixed_size_list(field_.type):
            flat = pa.array(values.astype(np.float32).reshape(-1), type=pa.float32())
            arrays.append(pa.FixedSizeListArray.from_arrays(flat, field_.type.list_size))
        else:
            dtype = np.float32 if pa.types.is_floating(field_.type) else np.int64
            arrays.append(pa.array(values.reshape(-1).astype(dtype), type=field_.type))
    return pa.Table.from_arrays(arrays, schema=schema)


def write_tasks(tasks: list[str], root: Path) -> None:
    """meta/tasks.parquet: LeRobot reads it with pandas and looks a task up by the frame's index; the task strings
    are the frame's index, so the file carries pandas' own metadata for that index (what pandas' to_parquet writes)."""
    table = pa.table({"task_index": pa.array(range(len(tasks)), type=pa.int64()),
                      "__index_level_0__": pa.array(tasks, type=pa.string())})
    pandas_metadata = {
        "index_columns": ["__index_level_0__"],
        "column_indexes": [{"name": None, "field_name": None, "pandas_type": "unicode", "numpy_type": "object",
                            "metadata": {"encoding": "UTF-8"}}],
        "columns": [{"name": "task_index", "field_name": "task_index", "pandas_type": "int64",
                     "numpy_type": "int64", "metadata": None},
                    {"name": None, "field_name": "__index_level_0__", "pandas_type": "unicode",
                     "numpy_type": "object", "metadata": None}],
        "creator": {"library": "pyarrow", "version": pa.__version__},
        "pandas_version": "2.2.3",
    }
    table = table.replace_schema_metadata({b"pandas": json.dumps(pandas_metadata).encode()})
    path = root / TASKS_PATH
    path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(table, path)


def write_episodes(rows: list[dict[str, Any]], root: Path, types: dict[str, pa.DataType] | None = None) -> None:
    """meta/episodes/chunk-000/file-000.parquet: one row an episode (columns in the order of the first row; a
    column's type inferred from its values unless ``types`` names it, e.g. a flag that may be unset in all)."""
    types = types or {}
    columns = {key: pa.array([row[key] for row in rows], type=types.get(key)) for key in rows[0]}
    path = root / EPISODES_PATH.format(chunk_index=0, file_index=0)
    path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(pa.table(columns), path, compression="snappy")


def feature_stats(values: np.ndarray, axis: int | tuple[int, ...] = 0) -> dict[str, np.ndarray]:
    """min, max, mean, std, count and the quantiles of ``values`` over ``axis`` (the frames), as LeRobot keeps
    them (count: the number of frames, shape (1,))."""
    values = np.asarray(values, dtype=np.float64)
    stats = {"min": values.min(axis=axis), "max": values.max(axis=axis), "mean": values.mean(axis=axis),
             "std": values.std(axis=axis), "count": np.array([values.shape[0]])}
    for quantile in QUANTILES:
        stats[f"q{round(quantile * 100):02d}"] = np.quantile(values, quantile, axis=axis)
    return stats


def image_stats(frames: np.ndarray) -> dict[str, np.ndarray]:
    """A camera's statistics per channel in [0, 1], shaped (3, 1, 1), over sampled frames (n x h x w x 3)."""
    stats = feature_stats(np.asarray(frames, dtype=np.float64) / 255.0, axis=(0, 1, 2))
    shaped = {key: value.reshape(3, 1, 1) for key, value in stats.items() if key != "count"}
    shaped["count"] = np.array([len(frames)])
    return shaped


def json_stats(stats: dict[str, dict[str, np.ndarray]]) -> dict[str, dict[str, list]]:
    return {key: {name: np.asarray(value).tolist() for name, value in feature.items()}
            for key, feature in stats.items()}


def flat_stats(stats: dict[str, dict[str, np.ndarray]]) -> dict[str, list]:
    """Per-episode statistics as the episodes file's ``stats/<feature>/<stat>`` columns."""
    return {f"stats/{key}/{name}": np.asarray(value).tolist()
            for key, feature in stats.items() for name, value in feature.items()}
