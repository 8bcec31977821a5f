"""Simulation tests import sim_bridge from the source tree when it is not installed (before colcon has built it).

Checked without importing: from the repository root, ``import sim_bridge`` would find the outer ``sim_bridge/``
folder as an empty namespace package and then fail on its modules.
"""
import importlib.util
import sys
from pathlib import Path

_spec = importlib.util.find_spec("sim_bridge")
if _spec is None or _spec.origin is None:  # absent, or only the namespace package of the repository root
    sys.modules.pop("sim_bridge", None)
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "sim_bridge"))
