"""Experiment machinery for E1-E4 (docs/EXPERIMENTS.md): the sweep stability criterion and bag time series.

Pure Python (numpy, mcap): nothing here imports rclpy, so the criterion can be tested on synthetic signals and
applied to any recorded bag. The driver that runs the graph is paper_experiments.py (scripts/experiments.sh), a
thin CLI over runner.py and plots.py; the other command lines here run with ``python -m sim_bridge.experiments.<name>``
(claims_sweep, evidence_sweep, run_in_process, e2_in_process, e2_twin, graph_passivity, engine_bench,
starvation_repro, obstacle_clearance).
"""
from sim_bridge.experiments.stability import (StabilityCriterion, StabilityInputError, StabilityVerdict,
                                              assess_stability, oscillation_components)

__all__ = ["StabilityCriterion", "StabilityInputError", "StabilityVerdict", "assess_stability",
           "oscillation_components"]
