"""The installed replica_node as a real process over DDS, with a test-side robot publishing joint states.

Checks: nothing is published before the first joint state; the torques it publishes are finite and inside the
Panda's torque and torque-rate limits; at rest it holds the arm (gravity compensation); a NaN teleoperation
command is refused with a log line and the last good x_d' kept; a good one is approached without a jump; the
watchdog says when the master goes silent; invalid run-time parameters are refused, and so is any change of the
input authority's bounds (read-only); Ctrl-C stops it cleanly.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import CONFIG
from replica_side import Robot

rclpy = pytest.importorskip("rclpy")
fic_teleop_msgs = pytest.importorskip("fic_teleop_msgs.msg")

from fic_core.limits import PandaLimits  # noqa: E402
from fic_core.panda_description import NOMINAL_CONFIGURATION  # noqa: E402
from fic_core.robot_model import RobotModel  # noqa: E402


def test_replica_node_end_to_end(start_node, ros_env, rclpy_context) -> None:
    replica = start_node("fic_teleop_replica", "replica_node", params_file=CONFIG / "replica.yaml",
                         params={"master_timeout": 0.3, "status_rate": 1000.0})
    assert replica.wait_for_output("waiting for /joint_states", timeout=60.0), replica.output()
    assert rclpy_context.ok()
    robot = Robot(rclpy_context)
    limits = PandaLimits.from_robot(RobotModel())
    torque_max = np.array(limits.torque)

    # Before the first joint state: nothing (matched first, so that nothing could have been lost on the way).
    robot.wait_for_replica()
    robot.spin(1.0)
    assert robot.commands == [] and robot.fic_states == []

    # At rest, no master, no planner: it holds the arm where it is (gravity compensation, nothing to shape).
    assert robot.publish_until(lambda: len(robot.commands) > 20 and robot.limit_status), replica.output()
    commands = np.array(robot.commands)
    assert commands.shape[1] == 7
    assert np.all(np.isfinite(commands))
    assert np.all(np.abs(commands) <= torque_max + 1e-9)
    assert np.all(np.abs(np.diff(commands, axis=0)) <= limits.torque_rate * 0.001 + 1e-9)
    model = RobotModel()
    model.update(NOMINAL_CONFIGURATION, np.zeros(7))
    np.testing.assert_allclose(commands[-1], model.gravity, atol=0.05)
    assert robot.limit_status and robot.limit_status[-1].violations == 0
    assert robot.fic_states[-1].controller == "fic"
    assert not robot.fic_states[-1].master_stale

    # A NaN teleoperation command is refused, with a log line; the replica keeps going.
    count = len(robot.commands)
    robot.publish_teleop([math.nan, 0.0, 0.0])
    assert robot.publish_until(lambda: "refusing /replica/teleop_command" in replica.output()
                               and len(robot.commands) > count), replica.output()
    assert np.all(np.isfinite(np.array(robot.commands)))
    assert abs(robot.fic_states[-1].error[0]) < 1e-6  # the NaN did not move x_d

    # A good command: x_d' approaches it at resume_speed (0.1 m/s), no jump; the torque stays in its limits.
    # Judged on joint-state time, the clock of the law's dt: each tick's FicState (x_d - x) is paired with its
    # LimitStatus (the joint state's stamp, the tick count), both published by that tick, in that order.
    assert robot.spin_until(lambda: len(robot.fic_states) == len(robot.limit_status), 30.0)
    start = len(robot.fic_states)
    assert robot.publish_until(lambda: robot.fic_states[start:] and robot.fic_states[-1].error[0] > 0.015,
                               teleop_offset=[0.02, 0.0, 0.0]), replica.output()
    assert robot.spin_until(lambda: len(robot.fic_states) == len(robot.limit_status), 30.0), \
        (len(robot.fic_states), len(robot.limit_status))
    errors = np.array([state.error[0] for state in robot.fic_states[start:]])
    stamps = np.array([_stamp_ns(status.header.stamp) for status in robot.limit_status[start:]]) * 1e-9
    ticks = np.array([status.ticks for status in robot.limit_status[start:]])
    assert errors.max() > 0.015, errors[-5:]
    assert errors.max() <= 0.02 + 1e-9
    # No jump: each tick gives back resume_speed times its dt, the interval between the joint-state stamps of two
    # ticks (raised to half a period when shorter: the schedule's floor), so between two reports x_d' moves at
    # most 0.1 m/s times the stamps' interval plus 0.5 ms for each tick in between.
    steps = np.diff(errors)
    allowed = 0.1 * (np.diff(stamps) + 0.0005 * np.diff(ticks))
    assert np.all(steps >= -1e-9), steps.min()
    assert np.all(steps <= allowed + 1e-9), (steps.max(), (steps - allowed).max())
    # Over the whole approach, likewise: not faster than resume_speed.
    first, arrived = np.argmax(errors > 1e-6), np.argmax(errors > 0.015)
    travelled = errors[arrived] - errors[first]
    assert travelled <= 0.1 * (stamps[arrived] - stamps[first] + 0.0005 * (ticks[arrived] - ticks[first])) + 1e-9
    commands = np.array(robot.commands)
    assert np.all(np.abs(commands) <= torque_max + 1e-9)
    assert np.all(np.abs(np.diff(commands, axis=0)) <= limits.torque_rate * 0.001 + 1e-9)

    # The master goes silent: after master_timeout the watchdog holds x_d' and says so once.
    def held_states() -> list[float]:
        return [state.error[0] for state in robot.fic_states if state.master_stale]
    assert robot.publish_until(lambda: "holding the last desired offset" in replica.output()
                               and len(held_states()) > 10), replica.output()
    assert robot.fic_states[-1].master_stale
    assert replica.output().count("holding the last desired offset") == 1
    held = held_states()
    assert len(held) > 10 and max(held) - min(held) < 1e-9  # x_d' held still while stale, not dropped
    assert errors[-1] - 1e-9 <= held[0] <= 0.02 + 1e-9

    # Run-time parameters: invalid values are refused with a reason, valid ones taken.
    ok, reason = robot.set_parameter("translation_max_force", math.nan)
    assert not ok
    ok, reason = robot.set_parameter("controller", "pid")
    assert not ok and "controller" in reason
    ok, reason = robot.set_parameter("translation_max_force", 1.0)  # below F0 = xi*K0*x_b = 5 N
    assert not ok and reason
    ok, reason = robot.set_parameter("control_rate", 100.0)
    assert ok, reason
    # The input authority's bounds are fixed at start (read-only rows): rclpy refuses a live change, as
    # ``ros2 param set`` sends it, and x_d' stays inside the bound of the start.
    ok, reason = robot.set_parameter("offset_workspace", 0.01)
    assert not ok and "read-only" in reason and "offset_workspace" in reason, reason
    assert robot.publish_until(lambda: robot.fic_states[-1].error[0] > 0.025, teleop_offset=[0.03, 0.0, 0.0]), \
        (robot.fic_states[-1].error[0], replica.output())   # 0.01 m would have clamped x_d' there

    # Ctrl-C: a clean exit.
    assert replica.stop(timeout=15.0) == 0, replica.log_path.read_text()
    assert "replica stopped" in replica.log_path.read_text()


def _stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def test_replica_below_the_joint_state_rate(start_node, ros_env, rclpy_context) -> None:
    """Realtime rates: a 250 Hz law on 1 kHz joint states answers only at control ticks (the robot holds in
    between), and its 50 Hz status still counts every tick (cumulative counters). Counted against the joint
    states' stamps, the replica's clock for its grid (not the test's wall time, which a loaded machine
    stretches)."""
    replica = start_node("fic_teleop_replica", "replica_node", params_file=CONFIG / "replica.yaml",
                         params={"control_rate": 250.0, "status_rate": 50.0, "answer_every_state": False,
                                 "diagnostics_rate": 10.0})
    assert replica.wait_for_output("waiting for /joint_states", timeout=60.0), replica.output()
    robot = Robot(rclpy_context)
    robot.wait_for_replica()
    robot.publish_joint_states(3.0, period=0.001)
    ticks = robot.replica_ticks_when_quiet(robot.state_stamps[-1])
    # Every tick sends one command; so does a tick of the loop's own hold (a loaded machine's tick gap over its
    # bound: fic_core.loop_health), at most one per held tick and one as each hold begins. All of them here once
    # the reliable stream delivered.
    assert robot.spin_until(lambda: len(robot.commands) >= ticks and len(robot.fic_states) == len(robot.limit_status),
                            30.0), (ticks, len(robot.commands), replica.output())
    held = int(robot.loop_health.get("held_ticks", "0")) + int(robot.loop_health.get("holds", "0"))
    assert ticks > 0 and ticks <= len(robot.commands) <= ticks + held, (ticks, len(robot.commands), robot.loop_health)
    # The grid on joint-state time: ticks at least 1/250 s apart less half a command period (the slack of the
    # schedule), the status at least 1/50 s less that slack; never one command a state.
    span = (robot.state_stamps[-1] - robot.state_stamps[0]) * 1e-9
    assert ticks <= span / (1.0 / 250.0 - 0.0005) + 1, (ticks, span)
    assert ticks < 0.5 * len(robot.state_stamps), (ticks, len(robot.state_stamps))
    assert robot.limit_status and len(robot.fic_states) <= span / (1.0 / 50.0 - 0.0005) + 1
    stamps = np.array([_stamp_ns(status.header.stamp) for status in robot.limit_status]) * 1e-9
    assert np.all(np.diff(stamps) >= 1.0 / 50.0 - 0.0005 - 1e-9), np.diff(stamps).min()
    # Every control tick is counted although only about one in five is published: after the last status at most
    # the five ticks 4 ms apart that fit before the next one was due.
    assert 0 <= ticks - robot.limit_status[-1].ticks <= 5, (ticks, robot.limit_status[-1].ticks)
    assert robot.limit_status[-1].ticks > 2 * len(robot.limit_status)
    assert replica.stop(timeout=15.0) == 0, replica.log_path.read_text()


@pytest.mark.parametrize("tick_on_command", [True, False])
def test_a_new_command_is_used_at_the_next_joint_state(start_node, ros_env, rclpy_context, tick_on_command) -> None:
    """tick_on_command: a 50 Hz law (20 ms grid) on 1 kHz joint states uses each new 30 Hz teleoperation command at
    the next joint state, not at the next tick of its grid: the ticks off the grid are those that first use a new
    command, at most one per command, and commands get one. Off, the law keeps its grid: every tick is at
    least one period (less the schedule's slack) of joint-state time after the one before, commands or not.

    Read per tick from the replica's own reports, not from wall-clock ages: with status_rate above the control
    rate every tick publishes a LimitStatus (the joint state's stamp and the cumulative tick count) and a FicState
    (the stamp of the command the tick used), in that callback, in that order."""
    replica = start_node("fic_teleop_replica", "replica_node", params_file=CONFIG / "replica.yaml",
                         params={"control_rate": 50.0, "status_rate": 1000.0, "answer_every_state": False,
                                 "tick_on_command": tick_on_command, "diagnostics_rate": 10.0})
    assert replica.wait_for_output("waiting for /joint_states", timeout=60.0), replica.output()
    robot = Robot(rclpy_context)
    robot.wait_for_replica()
    robot.publish_joint_states(0.5, period=0.001)  # started, holding, before the commands
    robot.publish_joint_states(4.0, period=0.001, teleop_offset=(0.0, 0.0, 0.0), teleop_period=1.0 / 30.0)
    sent = len(robot.teleop_stamps)
    last_command = robot.teleop_stamps[-1]
    # Joint states go on until a tick has used the last command (the next one, or the next tick of the grid).
    assert robot.publish_until(lambda: any(_stamp_ns(state.master_stamp) == last_command
                                           for state in robot.fic_states[-50:]), period=0.001), replica.output()
    ticks = robot.replica_ticks_when_quiet(robot.state_stamps[-1])
    # A tick less than half a command period after the one before sends no status (at most one such, the last).
    assert robot.spin_until(lambda: len(robot.fic_states) == len(robot.limit_status)
                            and robot.limit_status and robot.limit_status[-1].ticks >= ticks - 1, 30.0), \
        (ticks, len(robot.fic_states), len(robot.limit_status))
    grid_period = 1.0 / 50.0 - 0.0005   # the schedule's grid: one period less half a command period of slack
    pairs = off_grid = first_uses = off_grid_first_uses = 0
    used = set()
    for (before, state_before), (after, state_after) in zip(
            zip(robot.limit_status, robot.fic_states), zip(robot.limit_status[1:], robot.fic_states[1:])):
        used.add(_stamp_ns(state_after.master_stamp))
        if after.ticks != before.ticks + 1:
            continue   # a tick without its status in between: not a pair of consecutive ticks
        pairs += 1
        on_grid = (_stamp_ns(after.header.stamp) - _stamp_ns(before.header.stamp)) * 1e-9 >= grid_period - 1e-9
        first_use = _stamp_ns(state_after.master_stamp) not in (0, _stamp_ns(state_before.master_stamp))
        off_grid += not on_grid
        first_uses += first_use
        off_grid_first_uses += first_use and not on_grid
        # The schedule's law, tick by tick: a tick off the grid is one that a new command started.
        assert on_grid or (tick_on_command and first_use), (tick_on_command, after.ticks)
    used.discard(0)
    assert pairs >= 50, (pairs, len(robot.limit_status), ticks)   # 50 Hz ticks: about 230 quiet, 100 at load 14
    assert len(used) > 0.5 * sent, (len(used), sent)   # every command is used (fewer if the replica coalesced)
    if tick_on_command:
        # Commands start ticks of their own (one that arrives as the grid is due is used by the grid's tick: 91 of
        # 120 started their own at a load of 10 on 2 cores; off, none can).
        assert off_grid_first_uses >= 0.25 * first_uses > 0, (off_grid_first_uses, first_uses)
    else:
        assert off_grid == 0 and first_uses > 0, (off_grid, first_uses)
    assert replica.stop(timeout=15.0) == 0, replica.log_path.read_text()
