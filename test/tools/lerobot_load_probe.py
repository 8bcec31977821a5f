"""Load a dataset with LeRobot's own class and print what it read as JSON (run in .venv-lerobot, which holds
lerobot-dataset and torch; test_dataset_lerobot_load.py compares the output with the bag).

Usage: python lerobot_load_probe.py DATASET_ROOT INDEX [INDEX ...]
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import datasets
import pyarrow.parquet as pq
from ledataset.datasets.lerobot_dataset import CODEBASE_VERSION, LeRobotDataset
from ledataset.datasets.utils import get_hf_features_from_features


def main(root: str, indices: list[int]) -> None:
    # The "pyav" decoder (torchvision's PyAV reader): torchcodec needs FFmpeg's libraries on the system.
    dataset = LeRobotDataset("fic_teleop/export_test", root=root, video_backend="pyav")
    items = []
    for index in indices:
        item = dataset[index]
        image = item["observation.images.scene"]
        items.append({
            "index": int(item["index"]), "episode_index": int(item["episode_index"]),
            "frame_index": int(item["frame_index"]), "timestamp": float(item["timestamp"]), "task": item["task"],
            **{key: item[key].tolist() for key in ("observation.state", "observation.wrench",
                                                   "observation.handle.pose", "observation.handle.wrench", "action")},
            "image_shape": list(image.shape), "image_mean": float(image.mean()),
            "image_min": float(image.min()), "image_max": float(image.max()),
        })
    episodes = dataset.meta.episodes
    # The data files' schema against the one LeRobot's writer gives the same features (types and metadata).
    schema = pq.read_schema(Path(root) / dataset.meta.get_data_file_path(0))
    expected = get_hf_features_from_features(dataset.meta.features)
    print(json.dumps({
        "schema_as_lerobot_writes_it": datasets.Features.from_arrow_schema(schema) == expected
        and schema.types == expected.arrow_schema.types
        and json.loads(schema.metadata[b"huggingface"]) == json.loads(expected.arrow_schema.metadata[b"huggingface"]),
        "codebase_version": CODEBASE_VERSION, "fps": dataset.fps, "num_frames": dataset.num_frames,
        "num_episodes": dataset.num_episodes, "features": sorted(dataset.features),
        "camera_keys": dataset.meta.camera_keys, "length": len(dataset),
        "stats_keys": sorted(dataset.meta.stats), "tasks": list(dataset.meta.tasks.index),
        "episodes": [{key: episodes[i][key] for key in ("episode_index", "length", "success", "run", "start_time",
                                                        "dataset_from_index", "dataset_to_index")}
                     for i in range(len(episodes))],
        "items": items,
    }))


if __name__ == "__main__":
    main(sys.argv[1], [int(index) for index in sys.argv[2:]])
