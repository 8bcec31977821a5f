"""Master side of FIC haptic teleoperation: the master FIC with online haptic gain and the teleoperation modes (paper
Eq. 3)."""

# SIGINT/SIGTERM at any moment of the start-up end the node cleanly: the runtime takes them on import
# (fic_teleop_runtime/stop_signals.py), before the heavy imports of the node module.
import fic_teleop_runtime  # noqa: E402,F401
