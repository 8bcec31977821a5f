"""Experiment machinery for E1-E4 (docs/EXPERIMENTS.md): the sweep stability criterion and bag time series.

Pure Python (numpy, mcap): nothing here imports rclpy, so the criterion can be tested on synthetic signals and
applied to any recorded bag. The driver that runs the graph is scripts/experiments.py, a thin CLI over runner.py and plots.py.
"""
from sim_bridge.experiments.stability import (StabilityCriterion, StabilityInputError, StabilityVerdict,
                                              assess_stability, oscillation_components)

__all__ = ["StabilityCriterion", "StabilityInputError", "StabilityVerdict", "assess_stability",
           "oscillation_components"]
