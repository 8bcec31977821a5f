"""fic_teleop_runtime.periodic: a node's periodic callbacks on simulated time run on an rcl timer's deadlines as the
clock is set (each /clock message), whatever the executor; on wall time they are rclpy timers."""
from __future__ import annotations

import pytest
from rclpy.parameter import Parameter
from rclpy.time import Time
from rclpy.timer import Timer

from fic_teleop_runtime.periodic import PeriodicCallbacks, SimulatedTimer

MS = 1_000_000


def test_deadlines_are_a_period_apart_from_one_period_after_the_start_and_missed_ones_are_skipped():
    timer = SimulatedTimer(4 * MS, lambda: None, now_ns=0)
    fired = [t for t in range(0, 21) if timer.due(t * MS)]
    assert fired == [4, 8, 12, 16, 20]
    # A jump past three deadlines runs once, and the phase is kept (the next deadline is 36 ms, not 33).
    assert timer.due(33 * MS) and not timer.due(35 * MS) and timer.due(36 * MS)
    timer.cancel()
    assert timer.is_canceled() and not timer.due(100 * MS)
    with pytest.raises(ValueError):
        SimulatedTimer(0, lambda: None, now_ns=0)


def test_under_simulated_time_callbacks_run_as_the_clock_is_set(rclpy_context):
    from rclpy.node import Node

    node = Node("periodic_probe", context=rclpy_context,
                parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)])
    periodic = PeriodicCallbacks(node)
    assert periodic.simulated
    clock = node.get_clock()
    seen: dict[str, list[int]] = {"fast": [], "slow": []}
    periodic.create(0.004, lambda: seen["fast"].append(clock.now().nanoseconds // MS))
    slow = periodic.create(0.010, lambda: seen["slow"].append(clock.now().nanoseconds // MS))
    for step in range(1, 31):   # /clock every millisecond, as the lockstep simulation publishes it
        clock.set_ros_time_override(Time(nanoseconds=step * MS))
    assert seen == {"fast": [4, 8, 12, 16, 20, 24, 28], "slow": [10, 20, 30]}
    slow.cancel()
    clock.set_ros_time_override(Time(nanoseconds=45 * MS))   # a jump: the fast one once, the cancelled one never
    assert seen == {"fast": [4, 8, 12, 16, 20, 24, 28, 45], "slow": [10, 20, 30]}
    node.destroy_node()


def test_on_wall_time_they_are_ordinary_timers(rclpy_context):
    from rclpy.node import Node

    node = Node("periodic_wall_probe", context=rclpy_context)
    periodic = PeriodicCallbacks(node)
    assert not periodic.simulated
    assert isinstance(periodic.create(0.01, lambda: None), Timer)
    node.destroy_node()
