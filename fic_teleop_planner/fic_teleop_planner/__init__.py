"""Harmonic trajectory planner whose motion is superimposed on the operator's command (paper Eqs. 5-6)."""

# SIGINT/SIGTERM at any moment of the start-up end the node cleanly: the runtime takes them on import
# (fic_teleop_runtime/stop_signals.py), before the heavy imports of the node module.
import fic_teleop_runtime  # noqa: E402,F401
