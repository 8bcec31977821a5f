"""The lab (docs/EXPERIMENTS.md): E1-E4 on the graph and in process, the claims, their statistics, tables and plots,
the run verdict's labelled cases, and the developer tools (``fic_teleop_experiments.tools``).

The driver that runs the graph is paper_experiments.py (scripts/experiments.sh), a thin CLI over runner.py and
plots.py; the other command lines here run with ``python -m fic_teleop_experiments.<name>`` (claims_sweep,
evidence_sweep, run_in_process, e2_in_process, e2_twin, graph_passivity, engine_bench, starvation_repro,
obstacle_clearance). The packages below it: sim_bridge (the simulated world), fic_teleop_tools (recording, report,
run verdict), fic_teleop_bringup (the launcher), fic_core; none of them imports this one.
"""
# sim_bridge first: it chooses MuJoCo's OpenGL backend before any module here imports mujoco (the in-process runner
# does), and it has the node runtime take SIGINT/SIGTERM.
import sim_bridge  # noqa: F401
from fic_teleop_experiments.stability import (StabilityCriterion, StabilityInputError, StabilityVerdict,
                                              assess_stability, oscillation_components)

__all__ = ["StabilityCriterion", "StabilityInputError", "StabilityVerdict", "assess_stability",
           "oscillation_components"]
