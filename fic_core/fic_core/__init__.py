"""fic_core: the Fractal Impedance Controller's mathematics for haptic teleoperation (pure Python, no ROS).

The names below are loaded on first use (PEP 562), not at ``import fic_core``: every ``import fic_core.errors``
(the channel, the planner, the recorder, the launcher, the report) ran this file, and importing all of it pulled in
Pinocchio and SciPy, about 0.5 CPU-s a process for nodes that use neither (measured with ``python -X importtime``).
"""
from __future__ import annotations

import importlib

# name -> the module that defines it.
_EXPORTS = {
    # Control laws (paper Sec. II): profile (Eq. 1), attractor (Eq. 2), baseline, master (Eq. 3), teleoperation
    # modes, harmonic planner (Eqs. 5-6) and its trajectory sources.
    "FicInputError": "errors",
    "ForceProfile": "profile", "force_profile": "profile",
    "FractalAttractor": "attractor", "Phase": "attractor", "PoseAttractor": "pose_attractor",
    "LinearImpedance": "baseline", "make_baseline_like": "baseline",
    "MasterLaw": "master",
    "TeleoperationCommandIntegrator": "teleoperation", "TeleoperationMode": "teleoperation",
    "HarmonicPlanner": "planner",
    "Circle": "trajectories", "FixedPoint": "trajectories", "ViaPoints": "trajectories",
    "SampledSetPoint": "set_point", "ShrinkingOffset": "set_point",
    # Replica (paper Eq. 7, docs/CONTROL_LAWS.md): Pinocchio model, Panda limits, null-space posture, postural
    # optimisation.
    "RobotModel": "robot_model",
    "LimitFlag": "limits", "PandaLimits": "limits", "limit_violations": "limits",
    "NullSpacePosture": "posture",
    "PosturalOptimisation": "postural_optimisation", "ShapedTorque": "postural_optimisation",
    "rotation_from_quaternion": "quaternion", "unit_quaternion": "quaternion",
    "ReplicaCommand": "replica", "ReplicaController": "replica",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'fic_core' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"fic_core.{module}"), name)
    globals()[name] = value   # once loaded, a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
