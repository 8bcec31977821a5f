"""Turn a recorded session (rosbag2-layout MCAP bag) into metrics.json and the paper-style plots (docs/EXPERIMENTS.md,
"Metrics").

    python -m fic_teleop_tools.report <bag folder or .mcap> [--out DIR] [--warmup 2.0] [--f-max 15]

Pure Python (mcap, mcap-ros2-support, numpy, matplotlib); no rclpy. See metrics.py for the definitions.
The names below are loaded on first use (PEP 562): the launcher imports ``report.metrics`` for its targets after
every run, and this file's eager imports pulled matplotlib in with it (0.4 CPU-s a run).
"""
from __future__ import annotations

import importlib

_EXPORTS = {"BagData": "bag_data", "BagReadError": "bag_data", "load_bag": "bag_data",
            "TARGETS": "metrics", "Analysis": "metrics", "ReportSettings": "metrics", "analyse": "metrics",
            "make_report": "report", "summary_table": "report"}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
