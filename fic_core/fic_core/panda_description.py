"""The one place that knows where the Panda's URDF is and how Pinocchio loads it.

Both the controller (Pinocchio) and the simulator (MuJoCo, in sim_bridge) load
this very file, so the model the controller compensates is the model that moves.
"""
from __future__ import annotations

import sysconfig
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: Joint armature [kg m^2] and viscous damping [N m s/rad] of every arm joint.
#: The simulator applies them and the Pinocchio model mirrors the armature, so
#: M(q) agrees between the two to machine precision.
JOINT_ARMATURE = 0.1
JOINT_DAMPING = 0.5

ARM_JOINT_NAMES: tuple[str, ...] = tuple(f"panda_joint{i}" for i in range(1, 8))
FINGER_JOINT_NAMES: tuple[str, ...] = ("panda_finger_joint1", "panda_finger_joint2")
TCP_FRAME = "panda_hand_tcp"
HAND_FRAME = "panda_hand"

#: A comfortable, well-conditioned configuration (Franka's "ready" pose); the
#: null-space posture term pulls toward it.
NOMINAL_CONFIGURATION = np.array([0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398])


def _robot_data_root() -> Path:
    candidates = [Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"]
    try:  # a pip install elsewhere on sys.path (e.g. an existing ROS install using a user site)
        import cmeel  # type: ignore[import-not-found]

        prefix = Path(cmeel.__file__).resolve().parent.parent / "cmeel.prefix"
        candidates.append(prefix / "share" / "example-robot-data" / "robots")
    except ImportError:
        pass
    import site

    for path in site.getsitepackages() + [site.getusersitepackages()]:
        candidates.append(Path(path) / "cmeel.prefix" / "share" / "example-robot-data" / "robots")
    for candidate in candidates:
        if (candidate / "panda_description").is_dir():
            return candidate
    raise FileNotFoundError(
        "example-robot-data's Panda description was not found; install it with `pip install example-robot-data` "
        "(scripts/setup.sh does this)"
    )


@dataclass(frozen=True)
class PandaDescription:
    """Paths of the Panda description shipped by example-robot-data."""

    package_dir: Path
    urdf_path: Path
    mesh_dir: Path


def panda_description() -> PandaDescription:
    package_dir = _robot_data_root() / "panda_description"
    return PandaDescription(
        package_dir=package_dir,
        urdf_path=package_dir / "urdf" / "panda.urdf",
        mesh_dir=package_dir / "meshes",
    )


def load_pinocchio_model():
    """Load the 7-DoF Panda arm (fingers locked) into Pinocchio, with the simulator's joint armature.

    Returns ``(model, data, tcp_frame_id)``.
    """
    import pinocchio as pin

    description = panda_description()
    full_model = pin.buildModelFromUrdf(str(description.urdf_path))
    locked = [full_model.getJointId(name) for name in FINGER_JOINT_NAMES if full_model.existJointName(name)]
    model = pin.buildReducedModel(full_model, locked, pin.neutral(full_model))
    model.armature[:] = JOINT_ARMATURE
    data = model.createData()
    return model, data, model.getFrameId(TCP_FRAME)
