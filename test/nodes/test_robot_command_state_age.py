"""The simulated robot's rule on a torque's state (robot_node's command_state_timeout, realtime): a command that
names a joint state older than the bound is refused (never applied, the watchdog not released); one on a fresh
state is applied. The arm is pushed 20 N m on joint 1 by the refused commands and must not move."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from robot_side import Controller, stamp_ns, start_robot

rclpy = pytest.importorskip("rclpy")

from fic_core.command_stamp import label  # noqa: E402


def test_a_torque_on_an_old_state_is_refused_and_one_on_a_fresh_state_applied(ros_env, rclpy_context, tmp_path):
    from std_msgs.msg import MultiArrayDimension, MultiArrayLayout

    robot = start_robot(ros_env, tmp_path, mode="realtime", scene="free_space", command_state_timeout=0.05)
    controller = Controller(rclpy_context)
    controller.answering = False

    def send(age_s: float) -> None:
        state = controller.states[-1]
        q = np.array(state.position)
        torque = pin.computeGeneralizedGravity(controller.model, controller.data, q) + [20.0, 0, 0, 0, 0, 0, 0]
        layout = MultiArrayLayout(dim=[MultiArrayDimension(label=label(stamp_ns(state) - round(age_s * 1e9)),
                                                           size=7, stride=7)])
        controller.publisher.publish(controller._message(layout=layout, data=torque.tolist()))

    try:
        assert controller.spin_until(lambda: len(controller.states) > 200, 60.0), robot.output()
        start = np.array(controller.states[-1].position)
        for _ in range(300):   # commands on states 200 ms old, pushing joint 1 with 20 N m
            send(0.2)
            controller.executor.spin_once(timeout_sec=0.002)
        moved_old = abs(controller.states[-1].position[0] - start[0])
        assert "refused a torque command computed on a joint state" in robot.output(), robot.output()
        for _ in range(300):   # the same push on fresh states: applied
            send(0.0)
            controller.executor.spin_once(timeout_sec=0.002)
        moved_fresh = abs(controller.states[-1].position[0] - start[0])
        print(f"[robot] joint 1 moved {moved_old:.4f} rad under refused commands, {moved_fresh:.3f} rad after")
        assert moved_old < 0.005, moved_old
        assert moved_fresh > 0.05, moved_fresh
    finally:
        controller.node.destroy_node()
        assert robot.stop() == 0, robot.output()
