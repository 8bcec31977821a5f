"""Key frames of a recorded session: the arm's recorded joint positions replayed through the MuJoCo model.

Kinematics only (mj_kinematics), as sim_bridge.robot.render replays its tapes: the arm is where /joint_states says;
free objects of the scene are drawn at their initial poses (the bag's /sim/object_poses are not replayed).
"""
from __future__ import annotations

from pathlib import Path

from .bag_data import BagData


def render_key_frames(data: BagData, out: Path, scene: str, width: int = 640, height: int = 480) -> list[Path]:
    import sim_bridge  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported, when there is no display)

    # isort: split
    import mujoco

    from sim_bridge.robot.mujoco_panda import build_model
    from sim_bridge.robot.render import OffscreenRenderer, default_view, save_png

    if not data.key_joint_states:
        return []
    model, _ = build_model(scene)
    state = mujoco.MjData(model)
    t0 = data.key_joint_states[0][0]
    written = []
    with OffscreenRenderer(model, default_view(scene), width, height) as renderer:
        for stamp, names, positions in data.key_joint_states:
            for name, position in zip(names, positions):
                name = _model_joint_name(name, _joint_names(model))
                joint = model.joint(name) if name is not None else None
                if joint is not None:
                    state.qpos[joint.qposadr[0]] = position
            mujoco.mj_kinematics(model, state)
            mujoco.mj_camlight(model, state)
            written.append(save_png(renderer.render(state), out / f"key_frame_{stamp - t0:07.2f}s.png"))
    return written


def _model_joint_name(name: str, names: set[str]) -> str | None:
    """The model's joint for a recorded name: itself, or panda_joint<N> for another arm's <prefix>_joint<N>
    (an FR3 behind franka_ros2 is drawn with the Panda model, docs/HARDWARE.md)."""
    if name in names:
        return name
    stem, separator, number = name.rpartition("_joint")
    candidate = f"panda_joint{number}"
    return candidate if separator and stem and candidate in names else None


def _joint_names(model) -> set[str]:
    return {model.joint(i).name for i in range(model.njnt)}
