"""The starved replica's runaway, in process (docs/RESULTS.md "Starvation"): a law applied on joint states up to
150 ms old drives the arm past its datasheet speeds, and the replica's own loop check (fic_core.loop_health) with
the robot's bound on the age of a torque's state (robot_node's command_state_timeout) keeps it slow. The second
test fails on the code before them (the arm then reaches 20+ rad/s, as the first one shows). Without either, the
robot's velocity reflex (robot.yaml's velocity_reflex, on in the runner as in the robot node) stops the arm."""
from __future__ import annotations

import math

from fic_teleop_experiments.in_process import ReplicaStall, RunConfig, run

# Ticks on time (every 2-4 ms) for 1.5 s, each on a state 0-150 ms old: the two-station runaway's state ages.
OLD_STATES = ReplicaStall(2.0, 3.5, 0.002, 0.004, 0.0, 0.0, 0.0, 0.15)
PANDA_SLOWEST_JOINT = 2.175   # [rad/s] joints 1-4 of the datasheet
UNCHECKED = dict(replica_overrides={"loop_max_state_age": 10.0, "loop_max_tick_gap": 10.0},
                 robot_command_state_timeout=math.inf, robot_velocity_reflex=False)


def starved(**changes) -> object:
    return run(RunConfig(duration=4.0, control_rate=500.0, replica_stalls=(OLD_STATES,), **changes))


def test_the_law_on_old_states_runs_the_arm_away() -> None:
    result = starved(**UNCHECKED)
    assert result.joint_speed_max > 2 * PANDA_SLOWEST_JOINT, result.joint_speed_max


def test_the_loop_check_holds_the_arm_instead() -> None:
    result = starved()
    assert result.replica_holds >= 1
    assert result.joint_speed_max < 0.5 * PANDA_SLOWEST_JOINT, result.joint_speed_max
    assert result.tracking_error.max() < 0.15, result.tracking_error.max()
    assert result.limit_violations == 0


def test_the_robots_velocity_reflex_stops_the_runaway() -> None:
    """The law on old states, unchecked, against the robot as robot_node runs it: once a joint passes its datasheet
    speed by the reflex's margin the arm is held for the rest of the run."""
    result = starved(**{**UNCHECKED, "robot_velocity_reflex": None})
    assert result.velocity_reflex_time is not None
    assert OLD_STATES.start <= result.velocity_reflex_time < OLD_STATES.end, result.velocity_reflex_time
    assert result.joint_speed_max < 1.5 * PANDA_SLOWEST_JOINT, result.joint_speed_max
