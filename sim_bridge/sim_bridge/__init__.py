"""The simulated world: MuJoCo Panda with the paper's scenes, a sigma.7-class haptic device with a virtual operator,
and the delay/dropout channel (the recorder, report and CLI are fic_teleop_tools; the experiments and the developer
tools are fic_teleop_experiments, above this package)."""

import os as _os

# SIGINT/SIGTERM at any moment of the start-up end the node cleanly: the node runtime takes them on import
# (fic_teleop_runtime/stop_signals.py), first, before the imports.
import fic_teleop_runtime  # noqa: F401

# MuJoCo chooses its OpenGL backend once, when it is first imported, and without a display only EGL works here
# (Mesa llvmpipe; osmesa does not, docs/CONVENTIONS.md). Every sim_bridge module that imports mujoco goes through
# this package first, so this is the one place where the choice is made before the import.
if not _os.environ.get("DISPLAY") and not _os.environ.get("WAYLAND_DISPLAY"):
    _os.environ.setdefault("MUJOCO_GL", "egl")
