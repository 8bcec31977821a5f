"""The robot node as a real process over DDS, in lockstep: one joint state per physics step, the commands it
applies are the ones sent, bad commands are refused, and the watchdog holds the arm when commands stop."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

rclpy = pytest.importorskip("rclpy")

from robot_side import QOS, Controller, stamp_ns, start_robot  # noqa: E402

from sim_bridge.robot.mujoco_panda import HOLD_DAMPING  # noqa: E402


def test_lockstep_node_steps_on_each_command_refuses_bad_ones_and_holds_when_they_stop(ros_env, rclpy_context,
                                                                                      tmp_path):
    robot = start_robot(ros_env, tmp_path, mode="lockstep", scene="free_space", lockstep_timeout=0.1,
                         command_timeout=0.01, diagnostics_rate_hz=50.0)
    try:
        assert robot.wait_for_output("robot_sim ready", timeout=30.0), robot.output()
        controller = Controller(rclpy_context)
        # The simulation waits at t = 0, re-publishing its state, until the first command: then one step per answer.
        assert controller.spin_until(lambda: len(controller.sent) >= 400, timeout=40.0), robot.output()
        assert robot.wait_for_output("first torque command received", timeout=5.0)

        stamps = [stamp_ns(m) for m in controller.states]
        # Before the first step the initial state may come several times (stamp 0), then every physics step
        # once, 1 ms apart in simulation time (lockstep stamps are simulation time), none lost.
        first_step = next(i for i, stamp in enumerate(stamps) if stamp > 0)
        assert all(stamp == 0 for stamp in stamps[:first_step])
        np.testing.assert_array_equal(np.diff(stamps[first_step - 1:]), 1_000_000)
        # The torque applied in each step is the command sent in answer to the state before it (for the first
        # step: the answer to the last copy of the initial state) - or, on a step whose answer was later than
        # lockstep_timeout (a loaded machine), the previous torque held. Never a command from further back:
        # that would be a lasting lag of the commands behind the states.
        answer_to = {stamp: command for stamp, command in zip(stamps, controller.sent)}
        held_over = 0
        for k in range(first_step, len(stamps)):
            effort = np.array(controller.states[k].effort)
            if not np.array_equal(effort, answer_to[stamps[k] - 1_000_000]):
                np.testing.assert_array_equal(effort, controller.states[k - 1].effort)
                held_over += 1
        assert held_over <= 0.05 * (len(stamps) - first_step)

        # A NaN and a short command are refused and never applied.
        controller.answering = False
        controller.send_raw([float("nan")] * 7)
        controller.send_raw([1.0] * 6)
        assert robot.wait_for_output("rejected torque command", timeout=5.0), robot.output()
        # Commands stopped: after 10 ms of simulated time the watchdog holds the arm, and says so once.
        assert robot.wait_for_output("torque commands stale", timeout=10.0), robot.output()
        count_when_held = len(controller.states)
        assert controller.spin_until(lambda: len(controller.states) > count_when_held + 200, timeout=10.0)
        before, held = controller.states[-2], controller.states[-1]
        q, qd = np.array(before.position), np.array(before.velocity)
        # The hold torque, computed on the state before: gravity + Coriolis compensation and damping.
        hold = pin.nonLinearEffects(controller.model, controller.data, q, qd) - HOLD_DAMPING * qd
        np.testing.assert_allclose(held.effort, hold, rtol=0, atol=1e-9)
        # Fresh commands release it.
        controller.answering = True
        assert robot.wait_for_output("torque commands resumed", timeout=10.0) or \
            controller.spin_until(lambda: "torque commands resumed" in robot.output(), timeout=10.0), robot.output()
        assert robot.output().count("torque commands stale") == 1
        controller.node.destroy_node()
    finally:
        code = robot.stop(timeout=10.0)
    log = robot.log_path.read_text()
    assert code == 0, log  # a clean exit on SIGINT (what Ctrl-C sends)
    assert "robot_sim stopped" in log


def test_a_joint_beyond_its_velocity_limit_stops_the_arm_for_the_run(ros_env, rclpy_context, tmp_path):
    """A controller that keeps pushing joint 1 (60 N m on top of gravity compensation): once joint 1 passes the
    Panda's 2.175 rad/s by the reflex's 10 % the robot says so in one error line, applies its hold torque from then
    on whatever it is sent (Franka: joint_velocity_violation), and the arm comes to rest; /diagnostics says ERROR."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

    robot = start_robot(ros_env, tmp_path, mode="lockstep", scene="free_space", lockstep_timeout=0.1,
                         diagnostics_rate_hz=20.0)
    try:
        assert robot.wait_for_output("robot_sim ready", timeout=30.0), robot.output()
        controller = Controller(rclpy_context)
        statuses: list = []
        controller.node.create_subscription(DiagnosticArray, "/diagnostics",
                                            lambda m: statuses.extend(s for s in m.status if s.name == "robot_sim"), 10)
        controller.push = np.array([60.0, 0, 0, 0, 0, 0, 0])
        assert controller.spin_until(lambda: "reflex: panda_joint1 moved at" in robot.output(), timeout=60.0), \
            robot.output()
        tripped = len(controller.states)
        # 600 more steps of the same push: 0.6 s of simulated time.
        assert controller.spin_until(lambda: len(controller.states) > tripped + 600, timeout=60.0), robot.output()
        velocities = np.array([m.velocity for m in controller.states])
        before = np.abs(velocities[:tripped, 0]).max()
        assert 2.175 * 1.1 < before < 2.7, before   # it tripped on the first steps past limit and margin, not later
        # The hold torque on every step since (gravity + Coriolis compensation and damping), not the push.
        for previous, message in zip(controller.states[tripped + 1:-1], controller.states[tripped + 2:]):
            q, qd = np.array(previous.position), np.array(previous.velocity)
            hold = pin.nonLinearEffects(controller.model, controller.data, q, qd) - HOLD_DAMPING * qd
            np.testing.assert_allclose(message.effort, hold, rtol=0, atol=1e-9)
        # Braked to rest: under the limit within 0.2 s, nearly still after 0.6 s.
        assert np.abs(velocities[tripped + 200:]).max() < 2.175
        assert np.abs(velocities[-1]).max() < 0.05, velocities[-1]
        assert controller.spin_until(lambda: any(s.level == DiagnosticStatus.ERROR for s in statuses), 10.0)
        assert robot.output().count("reflex:") == 1
        controller.node.destroy_node()
    finally:
        code = robot.stop(timeout=10.0)
    assert code == 0, robot.log_path.read_text()


def test_realtime_joint_states_at_500_hz_lie_on_their_own_2_ms_grid_and_the_wrench_keeps_its_rate(
        ros_env, rclpy_context, tmp_path):
    """``joint_state_rate_hz: 500``: a state every second physics step, its stamps whole multiples of 2 ms (the
    recorder and the report count gaps on that grid), while /ft_sensor/wrench stays at 250 Hz."""
    from geometry_msgs.msg import WrenchStamped

    robot = start_robot(ros_env, tmp_path, mode="realtime", scene="free_space", joint_state_rate_hz=500.0)
    try:
        assert robot.wait_for_output("robot_sim ready", timeout=30.0), robot.output()
        controller = Controller(rclpy_context)
        wrenches: list = []
        controller.node.create_subscription(WrenchStamped, "/ft_sensor/wrench", wrenches.append, QOS)
        assert controller.spin_until(lambda: len(controller.states) >= 1000, timeout=30.0), robot.output()
        stamps_ns = np.array([stamp_ns(m) for m in controller.states[10:]])
        assert np.all(stamps_ns % 2_000_000 == 0)
        steps = np.diff(stamps_ns) / 2_000_000
        assert np.median(steps) == 1.0 and steps.min() >= 1.0
        span = (stamps_ns[-1] - stamps_ns[0]) * 1e-9
        wrench_rate = sum(1 for w in wrenches if stamp_ns(w) >= stamps_ns[0]) / span
        assert 200.0 < wrench_rate < 300.0, wrench_rate
    finally:
        robot.stop(timeout=10.0)
