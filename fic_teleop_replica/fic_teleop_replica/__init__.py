"""Replica side: the FIC torque controller with postural optimisation for a Panda-class arm (paper Eq. 7)."""

# SIGINT/SIGTERM at any moment of the start-up end the node cleanly (sim_bridge/stop_signals.py).
from sim_bridge import stop_signals as _stop_signals  # noqa: E402

_stop_signals.install_if_blocked()
