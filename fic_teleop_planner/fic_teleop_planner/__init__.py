"""Harmonic trajectory planner whose motion is superimposed on the operator's command (paper Eqs. 5-6)."""

# SIGINT/SIGTERM at any moment of the start-up end the node cleanly (sim_bridge/stop_signals.py).
from sim_bridge import stop_signals as _stop_signals  # noqa: E402

_stop_signals.install_if_blocked()
