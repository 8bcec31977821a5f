"""The in-process runner's starved replica (RunConfig.replica_stalls): in the window the replica answers only
after each drawn gap, its torque reaches the robot after the drawn delay, and the robot holds the last torque for
command_timeout, then its hold torque; deterministic per seed; outside the window the run is the plain one."""
from __future__ import annotations

import math

import numpy as np

from fic_teleop_experiments.in_process import ReplicaStall, RunConfig, run

STALL = ReplicaStall(2.0, 3.5, 0.02, 0.1, 0.01, 0.08)
# The stall's mechanics alone: the replica's own loop check and the robot's bound on a torque's state out of reach
# (test_starved_replica.py has them on).
UNCHECKED = dict(replica_overrides={"loop_max_state_age": 10.0, "loop_max_tick_gap": 10.0},
                 robot_command_state_timeout=math.inf, robot_velocity_reflex=False)


def test_a_starved_replica_answers_seldom_in_its_window_and_the_run_stays_deterministic() -> None:
    plain = run(RunConfig(duration=4.0))
    starved = run(RunConfig(duration=4.0, replica_stalls=(STALL,), **UNCHECKED))
    again = run(RunConfig(duration=4.0, replica_stalls=(STALL,), **UNCHECKED))
    np.testing.assert_array_equal(starved.tcp, again.tcp)
    # Before the window the two runs are the same run.
    before = plain.time < STALL.start
    np.testing.assert_array_equal(plain.tcp[before], starved.tcp[starved.time < STALL.start])
    # In it the replica's pose samples (pose_rate, 100 Hz) come only when it wakes: gaps of 20-100 ms and more.
    inside = starved.time[(starved.time >= STALL.start) & (starved.time < STALL.end)]
    gaps = np.diff(inside)
    assert gaps.max() >= 0.02 and len(inside) < 0.5 * (STALL.end - STALL.start) * 100
    # And the arm tracks worse than the plain run over the window and the second after it.
    window = lambda r: r.tracking_error[(r.time >= STALL.start) & (r.time < STALL.end + 0.5)].max()  # noqa: E731
    assert window(starved) > window(plain) + 0.005, (window(starved), window(plain))
