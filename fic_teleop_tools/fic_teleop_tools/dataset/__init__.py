"""Recorded runs as robot-learning data: the LeRobot v3.0 export (export.py) and what it is made of."""
