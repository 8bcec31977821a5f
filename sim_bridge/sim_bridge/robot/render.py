"""Pictures of the simulated world: key frames to PNG, a run to an animated GIF (or MP4), and the live viewer.

Offscreen rendering needs ``MUJOCO_GL=egl`` before mujoco is imported when there is no display; the package's
``__init__`` sets it (Debian packages libegl1, libegl-mesa0, libgl1-mesa-dri; software rendering on llvmpipe).
The robot is drawn with its collision meshes, coloured (mujoco_panda.py): 30-45 ms a 640x480 frame here, with
shadows and reflections off (they cost 5-10x).

A run is not rendered while it runs: 40 ms a frame would eat the 1 ms step budget. ``StateTape`` records the
joint positions (and which bonds are active) at a low rate, which costs microseconds, and ``render_tape`` replays
them through the kinematics at the end. Kinematics is all a picture needs.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np


@dataclass(frozen=True)
class CameraView:
    lookat: tuple[float, float, float]
    distance: float
    azimuth: float  # [deg] about z; 180 looks along +x (from behind the robot), 90 along +y
    elevation: float  # [deg], negative looks down


def default_view(scene: str) -> CameraView:
    """A three-quarter view from behind the robot's right shoulder, over the workspace (an operator's camera)."""
    if scene == "shape_sorting":
        return CameraView((0.42, 0.0, 0.22), 1.6, 40.0, -35.0)
    if scene == "superimposition":
        return CameraView((0.40, 0.0, 0.25), 1.6, 55.0, -28.0)
    return CameraView((0.25, 0.0, 0.35), 1.9, 55.0, -22.0)


class OffscreenRenderer:
    """Renders a model's state to RGB images with a fixed camera."""

    def __init__(self, model: mujoco.MjModel, view: CameraView, width: int = 640, height: int = 480) -> None:
        if not display_available() and not getattr(mujoco, "GLContext", object).__module__.startswith("mujoco.egl"):
            raise RuntimeError("offscreen rendering without a display needs MUJOCO_GL=egl before mujoco is first "
                               "imported: import sim_bridge before mujoco, or export MUJOCO_GL=egl")
        # The offscreen framebuffer must hold the image: grow it in the model if needed.
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        self._renderer = mujoco.Renderer(model, height=height, width=width)
        self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self._camera.lookat[:] = view.lookat
        self._camera.distance = view.distance
        self._camera.azimuth = view.azimuth
        self._camera.elevation = view.elevation

    def render(self, data: mujoco.MjData) -> np.ndarray:
        self._renderer.update_scene(data, camera=self._camera)
        return self._renderer.render().copy()

    def close(self) -> None:
        self._renderer.close()

    def __enter__(self) -> "OffscreenRenderer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def save_png(image: np.ndarray, path: str | Path) -> Path:
    import imageio.v3 as iio

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, image)
    return path


def check_video_path(path: str | Path) -> Path:
    """Raise ValueError early (at parameter time, not after an hour's run) if the format cannot be written."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".gif":
        return path
    if suffix == ".mp4":
        try:
            import imageio_ffmpeg  # noqa: F401  (imageio's MP4 writer)
        except ImportError as exc:
            raise ValueError(f"{path}: MP4 needs the imageio-ffmpeg package, which is not installed; "
                             "use a .gif path") from exc
        return path
    raise ValueError(f"{path}: the video must be .gif (or .mp4 with imageio-ffmpeg)")


def write_video(frames: list[np.ndarray], path: str | Path, fps: float) -> Path:
    import imageio.v3 as iio

    path = check_video_path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".gif":
        # Pillow's GIF writer takes the frame duration in milliseconds; loop=0 repeats forever.
        iio.imwrite(path, np.stack(frames), extension=".gif", duration=1000.0 / fps, loop=0)
    else:
        iio.imwrite(path, np.stack(frames), fps=fps)
    return path


class StateTape:
    """Low-rate record of the simulation's configuration, for rendering after the run."""

    def __init__(self, frame_interval: float) -> None:
        self._interval = float(frame_interval)
        self._next_time = 0.0
        self.times: list[float] = []
        self.qpos: list[np.ndarray] = []
        self.eq_active: list[np.ndarray] = []

    def maybe_record(self, data: mujoco.MjData) -> bool:
        if data.time + 1e-9 < self._next_time:
            return False
        self.times.append(float(data.time))
        self.qpos.append(data.qpos.copy())
        self.eq_active.append(data.eq_active.copy())
        self._next_time = data.time + self._interval
        return True

    def __len__(self) -> int:
        return len(self.times)


def render_tape(model: mujoco.MjModel, tape: StateTape, view: CameraView, video_path: str | Path | None = None,
                snapshot_dir: str | Path | None = None, snapshot_interval: float = 5.0, fps: float = 10.0,
                width: int = 640, height: int = 480) -> list[Path]:
    """Render a tape to a video and/or PNG key frames (one every ``snapshot_interval`` s, and the last)."""
    written: list[Path] = []
    if len(tape) == 0:
        return written
    data = mujoco.MjData(model)
    frames = []
    next_snapshot = 0.0
    with OffscreenRenderer(model, view, width, height) as renderer:
        for k, (t, qpos) in enumerate(zip(tape.times, tape.qpos)):
            data.qpos[:] = qpos
            data.time = t
            mujoco.mj_kinematics(model, data)
            mujoco.mj_camlight(model, data)  # lights are placed here, not in mj_kinematics: without it, a dark frame
            image = renderer.render(data)
            if video_path is not None:
                frames.append(image)
            if snapshot_dir is not None and (t + 1e-9 >= next_snapshot or k == len(tape) - 1):
                written.append(save_png(image, Path(snapshot_dir) / f"frame_{t:08.3f}s.png"))
                next_snapshot = t + snapshot_interval
    if video_path is not None:
        written.append(write_video(frames, video_path, fps))
    return written


def display_available() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def launch_viewer(model: mujoco.MjModel, data: mujoco.MjData):
    """The live MuJoCo viewer (passive: the caller steps and calls ``handle.sync()``), or None without a display."""
    if not display_available():
        return None
    import mujoco.viewer

    handle = mujoco.viewer.launch_passive(model, data, show_left_ui=False, show_right_ui=False)
    view = default_view("")
    with handle.lock():
        handle.cam.lookat[:] = view.lookat
        handle.cam.distance = view.distance
        handle.cam.azimuth = view.azimuth
        handle.cam.elevation = view.elevation
    return handle


__all__ = ["CameraView", "OffscreenRenderer", "StateTape", "check_video_path", "default_view", "display_available",
           "launch_viewer", "render_tape", "save_png", "write_video"]
