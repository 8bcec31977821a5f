"""`scripts/fic`: wheel-only stand-ins for the ros2 commands a user reaches for (docs/TOOLS.md).

ros2cli, launch and rosbag2 are not wheels, so these are built on what is: rclpy's graph queries, its parameter
client (the nodes' own parameter services) and the project's bag reader and writer (fic_teleop_tools.recording).
Every command that fails says why in one line on stderr and exits non-zero.
"""
