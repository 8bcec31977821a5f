"""The lab (docs/EXPERIMENTS.md): E1-E4 on the graph and in process, the claims, their statistics, tables and plots,
the run verdict's labelled cases, and the developer tools (``fic_teleop_experiments.tools``).

The driver that runs the graph is paper_experiments.py (scripts/experiments.sh), a thin CLI over runner.py and
plots.py; the other command lines here run with ``python -m fic_teleop_experiments.<name>`` (claims_sweep,
claims_report, claims_reproduce, run_in_process, e2 (its trials, sweep, graph trials and bond pulls),
graph_passivity, engine_bench, replica_response, verdict_cases). Every run is judged by the one run verdict,
fic_teleop_tools.verdict.run_verdict. The packages below this one: sim_bridge (the simulated world), fic_teleop_tools
(recording, report, run verdict), fic_teleop_bringup (the launcher), fic_core; none of them imports it.
"""
# sim_bridge first: it chooses MuJoCo's OpenGL backend before any module here imports mujoco (the in-process runner
# does), and it has the node runtime take SIGINT/SIGTERM.
import sim_bridge  # noqa: F401
