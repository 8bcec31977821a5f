"""The installed replica_node as a real process over DDS, with a test-side robot publishing joint states.

Checks: nothing is published before the first joint state; the torques it publishes are finite and inside the
Panda's torque and torque-rate limits; at rest it holds the arm (gravity compensation); a NaN teleoperation
command is refused with a log line and the last good x_d' kept; a good one is approached without a jump; the
watchdog says when the master goes silent; invalid run-time parameters are refused; Ctrl-C stops it cleanly.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import CONFIG, REPO

rclpy = pytest.importorskip("rclpy")
fic_teleop_msgs = pytest.importorskip("fic_teleop_msgs.msg")

from fic_core.limits import PandaLimits  # noqa: E402
from fic_core.panda_description import ARM_JOINT_NAMES, NOMINAL_CONFIGURATION  # noqa: E402
from fic_core.robot_model import RobotModel  # noqa: E402


def replica_env(ros_env: dict[str, str]) -> dict[str, str]:
    """The fixture's environment plus colcon's develop-mode build folder, where the entry point's metadata lives
    (colcon --symlink-install keeps fic_teleop_replica.egg-info in build/, which `install/setup.bash` adds via a
    hook that scripts/env.sh does not run)."""
    env = dict(ros_env)
    build = str(REPO / "build" / "fic_teleop_replica")
    env["PYTHONPATH"] = build + (":" + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


class Robot:
    """Test side: publishes /joint_states of an arm at rest and records what the replica publishes."""

    def __init__(self, context) -> None:
        from fic_teleop_msgs.msg import FicState, LimitStatus, TeleoperationCommand
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64MultiArray

        stream = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=50)
        status = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=20)
        # Deep reader histories: a test process that lags must not lose what it checks.
        record = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=5000)
        self.node = Node("test_robot", context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.joint_state_pub = self.node.create_publisher(JointState, "/joint_states", stream)
        self.teleop_pub = self.node.create_publisher(TeleoperationCommand, "/replica/teleop_command", status)
        self.commands: list[list[float]] = []
        self.fic_states: list = []
        self.limit_status: list = []
        self.node.create_subscription(Float64MultiArray, "/effort_controller/commands",
                                      lambda m: self.commands.append(list(m.data)), record)
        self.node.create_subscription(FicState, "/replica/fic_state", self.fic_states.append, record)
        self.node.create_subscription(LimitStatus, "/replica/limit_status", self.limit_status.append, record)
        self.JointState = JointState
        self.TeleoperationCommand = TeleoperationCommand
        # Shuffled joint order (and an extra finger joint): the replica must reorder by name.
        self.names = [ARM_JOINT_NAMES[i] for i in (3, 0, 6, 1, 5, 2, 4)] + ["panda_finger_joint1"]

    def spin(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.01)

    def publish_joint_states(self, seconds: float, period: float = 0.004, teleop_offset=None,
                             teleop_period: float = 0.004) -> None:
        """Joint states of the arm at rest at the nominal configuration, every ``period`` (wall clock)."""
        position = {name: value for name, value in zip(ARM_JOINT_NAMES, NOMINAL_CONFIGURATION)}
        position["panda_finger_joint1"] = 0.02
        deadline = time.monotonic() + seconds
        next_teleop = next_state = time.monotonic()
        while time.monotonic() < deadline:
            while time.monotonic() < next_state:  # paced: the replica must not be flooded
                self.executor.spin_once(timeout_sec=max(0.0, next_state - time.monotonic()))
            next_state += period
            message = self.JointState()
            message.header.stamp = self.node.get_clock().now().to_msg()
            message.name = self.names
            message.position = [position[name] for name in self.names]
            message.velocity = [0.0] * len(self.names)
            self.joint_state_pub.publish(message)
            if teleop_offset is not None and time.monotonic() >= next_teleop:
                self.publish_teleop(teleop_offset)
                next_teleop += teleop_period

    def publish_teleop(self, offset) -> None:
        message = self.TeleoperationCommand()
        message.header.stamp = self.node.get_clock().now().to_msg()
        message.desired_offset.x, message.desired_offset.y, message.desired_offset.z = (float(v) for v in offset)
        message.haptic_gain = 0.5
        message.workspace_scale = 1.0
        self.teleop_pub.publish(message)

    def set_parameter(self, name: str, value) -> tuple[bool, str]:
        from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
        from rcl_interfaces.srv import SetParameters

        client = self.node.create_client(SetParameters, "/replica/set_parameters")
        assert client.wait_for_service(timeout_sec=10.0)
        parameter_value = ParameterValue()
        if isinstance(value, str):
            parameter_value.type, parameter_value.string_value = ParameterType.PARAMETER_STRING, value
        else:
            parameter_value.type, parameter_value.double_value = ParameterType.PARAMETER_DOUBLE, float(value)
        future = client.call_async(SetParameters.Request(parameters=[Parameter(name=name, value=parameter_value)]))
        deadline = time.monotonic() + 10.0
        while not future.done() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.05)
        self.node.destroy_client(client)
        result = future.result().results[0]
        return result.successful, result.reason


def test_replica_node_end_to_end(start_node, ros_env, rclpy_context) -> None:
    replica = start_node("fic_teleop_replica", "replica_node", params_file=CONFIG / "replica.yaml",
                         params={"master_timeout": 0.3, "status_rate": 1000.0}, env=replica_env(ros_env))
    assert replica.wait_for_output("waiting for /joint_states", timeout=60.0), replica.output()
    assert rclpy_context.ok()
    robot = Robot(rclpy_context)
    limits = PandaLimits.from_robot(RobotModel())
    torque_max = np.array(limits.torque)

    # Before the first joint state: nothing.
    robot.spin(1.5)
    assert robot.commands == [] and robot.fic_states == []

    # At rest, no master, no planner: it holds the arm where it is (gravity compensation, nothing to shape).
    robot.publish_joint_states(2.0)
    robot.spin(0.3)
    assert len(robot.commands) > 20, replica.output()  # about 500 published; fewer under heavy load
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
    robot.publish_joint_states(0.5)
    assert replica.wait_for_output("refusing /replica/teleop_command", timeout=5.0), replica.output()
    assert len(robot.commands) > count
    assert np.all(np.isfinite(np.array(robot.commands)))
    assert abs(robot.fic_states[-1].error[0]) < 1e-6  # the NaN did not move x_d

    # A good command: x_d' approaches it at resume_speed (0.1 m/s), no jump; the torque stays in its limits.
    robot.fic_states.clear()
    deadline = time.monotonic() + 20.0  # the pace depends on the machine's load: run until x_d' got there
    while time.monotonic() < deadline and not (robot.fic_states and robot.fic_states[-1].error[0] > 0.015):
        robot.publish_joint_states(0.5, teleop_offset=[0.02, 0.0, 0.0])
    errors = np.array([state.error[0] for state in robot.fic_states])
    computed = np.array([state.header.stamp.sec + 1e-9 * state.header.stamp.nanosec for state in robot.fic_states])
    assert errors.max() > 0.015, errors[-5:]
    assert errors.max() <= 0.02 + 1e-9
    # No jump: x_d' moves at resume_speed = 0.1 m/s of the joint states' clock (the control dt comes from their
    # stamps; this test sends one every 4 ms, so about 0.4 mm a tick). A tick's step may exceed 0.1 m/s times the
    # gap between the replica's own compute stamps by one joint-state period of scheduling jitter, never more.
    steps = np.diff(errors)
    assert np.all(steps >= -1e-9), steps.min()
    assert np.all(steps <= 0.1 * (np.diff(computed) + 0.004) + 1e-9), (steps.max(), np.diff(computed).max())
    # Over the whole approach, not faster than resume_speed (one joint-state period of slack at each end).
    first, arrived = np.argmax(errors > 1e-6), np.argmax(errors > 0.015)
    travelled, took = errors[arrived] - errors[first], computed[arrived] - computed[first]
    assert took >= travelled / 0.1 - 0.008, (travelled, took)
    commands = np.array(robot.commands)
    assert np.all(np.abs(commands) <= torque_max + 1e-9)
    assert np.all(np.abs(np.diff(commands, axis=0)) <= limits.torque_rate * 0.001 + 1e-9)

    # The master goes silent: after master_timeout the watchdog holds x_d' and says so once.
    robot.publish_joint_states(1.0)
    assert replica.wait_for_output("holding the last desired offset", timeout=5.0), replica.output()
    assert robot.fic_states[-1].master_stale
    assert replica.output().count("holding the last desired offset") == 1
    held = [state.error[0] for state in robot.fic_states if state.master_stale]
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

    # Ctrl-C: a clean exit.
    assert replica.stop(timeout=15.0) == 0, replica.log_path.read_text()
    assert "replica stopped" in replica.log_path.read_text()


def test_replica_below_the_joint_state_rate(start_node, ros_env, rclpy_context) -> None:
    """Realtime rates: a 250 Hz law on 1 kHz joint states answers only at control ticks (the robot holds in
    between), and its 50 Hz status still counts every tick (cumulative counters)."""
    replica = start_node("fic_teleop_replica", "replica_node", params_file=CONFIG / "replica.yaml",
                         params={"control_rate": 250.0, "status_rate": 50.0, "answer_every_state": False},
                         env=replica_env(ros_env))
    assert replica.wait_for_output("waiting for /joint_states", timeout=60.0), replica.output()
    robot = Robot(rclpy_context)
    robot.spin(1.0)
    started = time.monotonic()
    robot.publish_joint_states(3.0, period=0.001)
    robot.spin(1.0)
    published_for = time.monotonic() - started - 1.0
    assert robot.commands, replica.output()
    # One command a control tick: at most one per 4 ms of joint-state time (plus the first), never one a state.
    assert len(robot.commands) <= published_for * 250 * 1.1 + 2, (len(robot.commands), published_for)
    assert robot.limit_status and robot.fic_states
    assert len(robot.fic_states) <= published_for * 50 * 1.2 + 2
    # Every control tick is counted although only about one in five is published.
    assert abs(robot.limit_status[-1].ticks - len(robot.commands)) <= 5, (robot.limit_status[-1].ticks,
                                                                         len(robot.commands))
    assert robot.limit_status[-1].ticks > 2 * len(robot.limit_status)
    assert replica.stop(timeout=15.0) == 0, replica.log_path.read_text()


@pytest.mark.parametrize("tick_on_command", [True, False])
def test_a_new_command_is_used_at_the_next_joint_state(start_node, ros_env, rclpy_context, tick_on_command) -> None:
    """tick_on_command: a 50 Hz law (20 ms grid) on 1 kHz joint states uses each new 30 Hz teleoperation command at
    the next joint state, not at the next tick of its grid: the command's age at first use (FicState.master_age)
    stays within a few ms, for at most one extra tick per command. Off, the law keeps its grid: the age is spread
    over the 20 ms period (the 33 ms command period sweeps every phase of it; commands at the grid's own period
    would all meet it at one phase) and the tick count is the grid's."""
    replica = start_node("fic_teleop_replica", "replica_node", params_file=CONFIG / "replica.yaml",
                         params={"control_rate": 50.0, "status_rate": 100.0, "answer_every_state": False,
                                 "tick_on_command": tick_on_command}, env=replica_env(ros_env))
    assert replica.wait_for_output("waiting for /joint_states", timeout=60.0), replica.output()
    robot = Robot(rclpy_context)
    robot.spin(1.0)
    robot.publish_joint_states(0.5, period=0.001)  # started, holding, before the commands
    started_ticks = robot.limit_status[-1].ticks if robot.limit_status else 0
    started = time.monotonic()
    robot.publish_joint_states(4.0, period=0.001, teleop_offset=(0.0, 0.0, 0.0), teleop_period=1.0 / 30.0)
    published_for = time.monotonic() - started
    robot.spin(1.0)
    first_use_age = {}
    for state in robot.fic_states:
        stamp = state.master_stamp.sec * 1_000_000_000 + state.master_stamp.nanosec
        if stamp:
            first_use_age.setdefault(stamp, state.master_age)
    ages_ms = np.array(list(first_use_age.values())) * 1e3
    assert len(ages_ms) > 0.5 * published_for * 30, (len(ages_ms), replica.output())
    ticks_per_s = (robot.limit_status[-1].ticks - started_ticks) / published_for
    if tick_on_command:
        assert np.median(ages_ms) < 4.0, np.percentile(ages_ms, [50, 90])
        # The tick comes sooner and the grid restarts from it: at most one extra tick per command.
        assert 0.9 * 50 < ticks_per_s < 1.15 * (50 + 30), ticks_per_s
    else:
        assert np.median(ages_ms) > 5.0, np.percentile(ages_ms, [50, 90])
        assert ticks_per_s < 1.15 * 50, ticks_per_s
    assert replica.stop(timeout=15.0) == 0, replica.log_path.read_text()
