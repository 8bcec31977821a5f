"""Turn a recorded session (rosbag2-layout MCAP bag) into metrics.json and the paper-style plots (docs/EXPERIMENTS.md, "Metrics").

    python -m fic_teleop_tools.report <bag folder or .mcap> [--out DIR] [--warmup 2.0] [--f-max 15]

Pure Python (mcap, mcap-ros2-support, numpy, matplotlib); no rclpy. See metrics.py for the definitions.
"""
from .bag_data import BagData, BagReadError, load_bag
from .metrics import TARGETS, Analysis, ReportSettings, analyse
from .report import make_report, summary_table

__all__ = ["Analysis", "BagData", "BagReadError", "ReportSettings", "TARGETS", "analyse", "load_bag",
           "make_report", "summary_table"]
