"""Tools for a session with a real or simulated robot, none of which needs the simulator (MuJoCo): the recorder
node, the MCAP bag writer, reader and recovery, and the live view (recording); the session report, its metrics
and verdicts (report); ros2-style commands (cli). docs/ARCHITECTURE.md says why they are a package of their own.

Importing this package first thing takes SIGINT and SIGTERM (the node runtime, fic_teleop_runtime/stop_signals.py)
before the imports that follow, so a stop during the recorder's start ends it cleanly.
"""
import fic_teleop_runtime  # noqa: F401
