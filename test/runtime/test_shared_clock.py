"""fic_teleop_runtime.shared_clock: the nodes of one process that follow the same /clock topic take it through one
subscription, and each node's clock (with its jump callbacks) is still set by every message; a node whose /clock is
remapped elsewhere, or that is on wall time, keeps its own."""
from __future__ import annotations

import time

from builtin_interfaces.msg import Time
from rclpy.clock import JumpThreshold
from rclpy.duration import Duration
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from fic_teleop_runtime.shared_clock import share_clock_subscription

SIM_TIME = [Parameter("use_sim_time", Parameter.Type.BOOL, True)]


def test_one_subscription_per_clock_topic_drives_every_member_clock(rclpy_context):
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    first = Node("shared_clock_first", context=rclpy_context, parameter_overrides=SIM_TIME)
    second = Node("shared_clock_second", context=rclpy_context, parameter_overrides=SIM_TIME)
    remapped = Node("shared_clock_remapped", context=rclpy_context, parameter_overrides=SIM_TIME,
                    cli_args=["--ros-args", "-r", "/clock:=/sim/step_clock"])
    wall = Node("shared_clock_wall", context=rclpy_context)
    jumps: list[int] = []
    handle = second.get_clock().create_jump_callback(   # kept: the callback lives as long as its handle
        JumpThreshold(min_forward=Duration(nanoseconds=1), min_backward=None, on_clock_change=False),
        post_callback=lambda _jump: jumps.append(second.get_clock().now().nanoseconds))

    assert share_clock_subscription([first, second, remapped, wall]) == 1

    publisher = wall.create_publisher(Clock, "/clock", 10)
    deadline = time.monotonic() + 10.0
    while (publisher.get_subscription_count() < 1 or wall.count_subscribers("/sim/step_clock") < 1) \
            and time.monotonic() < deadline:
        time.sleep(0.05)
    assert wall.count_subscribers("/clock") == 1   # the second node's own subscription is gone
    assert wall.count_subscribers("/sim/step_clock") == 1
    executor = SingleThreadedExecutor(context=rclpy_context)
    for node in (first, second, remapped, wall):
        executor.add_node(node)
    for second_of_time in (1, 2, 3):
        publisher.publish(Clock(clock=Time(sec=second_of_time)))
        end = time.monotonic() + 5.0
        while second.get_clock().now().nanoseconds < second_of_time * 10 ** 9 and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
    assert first.get_clock().now().nanoseconds == second.get_clock().now().nanoseconds == 3 * 10 ** 9
    assert jumps == [1 * 10 ** 9, 2 * 10 ** 9, 3 * 10 ** 9]
    assert remapped.get_clock().now().nanoseconds == 0   # its topic carried nothing
    executor.shutdown()
    del handle
