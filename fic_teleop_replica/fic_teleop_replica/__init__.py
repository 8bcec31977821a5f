"""Replica side: the FIC torque controller with postural optimisation for a Panda-class arm (paper Eq. 7)."""

# SIGINT/SIGTERM at any moment of the start-up end the node cleanly: the runtime takes them on import
# (fic_teleop_runtime/stop_signals.py), before the heavy imports of the node module.
import fic_teleop_runtime  # noqa: E402,F401
