"""The scene's camera, rendered after the run from what the bag holds, and written as an AV1 video with PyAV.

Rendering while the run goes would cost the realtime graph 16 ms of CPU a 640x480 frame (llvmpipe, measured
here), a third of a core at 30 frames a second, on a machine the graph already fills; after the run it costs only
time. A frame is the MuJoCo scene placed as the frame's time saw it: the arm at the held /joint_states, each movable
body at the held /sim/object_poses (kinematics only, as sim_bridge.robot.render replays its tapes), seen from the
scene's camera (sim_bridge.robot.render.default_view, the view of the run's key frames).

The video is encoded as LeRobot's own writer does (libsvtav1, yuv420p, a key frame every 2 frames, crf 30, preset
12), one frame per dataset frame with presentation time frame / fps, so that LeRobot's decoder finds each frame at
its timestamp; consecutive episodes follow one another in one file.
"""
from __future__ import annotations

import os
from fractions import Fraction
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

CODEC = "libsvtav1"
CODEC_NAME = "av1"   # what a reader's stream reports (LeRobot's video info: video.codec)
PIX_FMT = "yuv420p"
ENCODER_OPTIONS = {"g": "2", "crf": "30", "preset": "12"}
STATS_FRAMES = 100   # frames an episode's camera statistics are taken over, spread evenly (LeRobot samples too)
STATS_STRIDE = 4     # every 4th pixel of them, each way


class SceneCamera:
    """Renders the scene's camera at given arm configurations and body poses."""

    def __init__(self, scene: str, joint_names: list[str], body_count: int, width: int, height: int) -> None:
        import sim_bridge  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported, when there is no display)

        # isort: split
        import mujoco

        from sim_bridge.robot.mujoco_panda import build_model
        from sim_bridge.robot.render import OffscreenRenderer, default_view

        self._mujoco = mujoco
        self._model, layout = build_model(scene)
        if len(layout.movable_bodies) != body_count:
            raise ValueError(f"the {scene} scene has {len(layout.movable_bodies)} movable bodies, the bag's object "
                             f"poses {body_count}: the run was not recorded in this scene")
        self._data = mujoco.MjData(self._model)
        model_joints = {self._model.joint(i).name for i in range(self._model.njnt)}
        unknown = [name for name in joint_names if name not in model_joints]
        if unknown:
            raise ValueError(f"the {scene} scene has no joint {', '.join(unknown)}")
        self._joint_qpos = np.array([self._model.joint(name).qposadr[0] for name in joint_names])
        # A movable body hangs on a free joint: its qpos is position then quaternion (w, x, y, z).
        self._body_qpos = np.array([self._model.joint(self._model.body(name).jntadr[0]).qposadr[0]
                                    for name in layout.movable_bodies], dtype=int)
        self._renderer = OffscreenRenderer(self._model, default_view(scene), width, height)

    def render(self, joint_positions: NDArray[np.float64], body_poses: NDArray[np.float64]) -> NDArray[np.uint8]:
        """One RGB frame (height x width x 3): ``body_poses`` is (x y z qx qy qz qw) per body, flattened."""
        qpos = self._data.qpos
        qpos[self._joint_qpos] = joint_positions
        for index, address in enumerate(self._body_qpos):
            x, y, z, qx, qy, qz, qw = body_poses[7 * index:7 * index + 7]
            qpos[address:address + 7] = (x, y, z, qw, qx, qy, qz)
        self._mujoco.mj_kinematics(self._model, self._data)
        self._mujoco.mj_camlight(self._model, self._data)  # lights follow the scene: without it, a dark frame
        return self._renderer.render(self._data)

    def close(self) -> None:
        self._renderer.close()


class VideoFile:
    """One video file of consecutive episodes: frames in, each at presentation time (its number in the file) / fps."""

    def __init__(self, path: Path, fps: int, width: int, height: int) -> None:
        import av

        # SVT-AV1 prints its settings on stderr at every file; errors only.
        os.environ.setdefault("SVT_LOG", "1")
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self.frames = 0
        self._container = av.open(str(path), "w")
        self._stream = self._container.add_stream(CODEC, rate=fps, options=dict(ENCODER_OPTIONS))
        self._stream.width, self._stream.height, self._stream.pix_fmt = width, height, PIX_FMT
        self._time_base = Fraction(1, fps)
        self._frame_class = av.VideoFrame

    def add(self, image: NDArray[np.uint8]) -> None:
        frame = self._frame_class.from_ndarray(np.ascontiguousarray(image), format="rgb24")
        frame.pts, frame.time_base = self.frames, self._time_base
        for packet in self._stream.encode(frame):
            self._container.mux(packet)
        self.frames += 1

    def close(self) -> None:
        for packet in self._stream.encode(None):
            self._container.mux(packet)
        self._container.close()

    def size_in_mb(self) -> float:
        return self.path.stat().st_size / 2**20 if self.path.exists() else 0.0


def stats_frame_numbers(length: int) -> set[int]:
    """Which of an episode's frames its camera statistics are taken over."""
    return {int(k) for k in np.linspace(0, length - 1, min(length, STATS_FRAMES)).round()}
