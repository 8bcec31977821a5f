"""The workspace itself: our messages cross real processes over DDS, every node executable is installed where
`ros2 run` finds it, and fic_core stands alone without ROS."""
from __future__ import annotations

import ast
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from conftest import INSTALL, REPO, installed_executable

NODE_PACKAGES = ("fic_teleop_master", "fic_teleop_replica", "fic_teleop_planner", "sim_bridge", "fic_teleop_tools")


def _console_scripts(package: str) -> list[str]:
    """The executables a package's setup.py declares (read from its source, not from what got installed)."""
    tree = ast.parse((REPO / package / "setup.py").read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Dict):
            for key, value in zip(node.keys, node.values):
                if isinstance(key, ast.Constant) and key.value == "console_scripts":
                    return [ast.literal_eval(item).split("=")[0].strip() for item in value.elts]
    raise AssertionError(f"{package}/setup.py declares no console_scripts")


@pytest.mark.parametrize("package", NODE_PACKAGES)
def test_executables_are_where_ros2_run_looks(package: str) -> None:
    from ament_index_python.packages import get_package_prefix

    executables = _console_scripts(package)
    assert executables, f"{package} declares no executables"
    assert Path(get_package_prefix(package)) == INSTALL / package
    assert (INSTALL / package / "share" / "ament_index" / "resource_index" / "packages" / package).exists()
    for executable in executables:
        path = installed_executable(package, executable)
        assert path.is_file() and os.access(path, os.X_OK), f"{path} missing or not executable"


def test_fic_core_imports_without_ros() -> None:
    # Any attempt to import a ROS package from fic_core fails loudly in this child interpreter.
    script = textwrap.dedent(
        """
        import importlib, pkgutil, sys
        class NoRos:
            def find_spec(self, name, path=None, target=None):
                if name.split('.')[0] in {'rclpy', 'rosidl_runtime_py', 'std_msgs', 'geometry_msgs',
                                          'sensor_msgs', 'fic_teleop_msgs', 'builtin_interfaces'}:
                    raise ImportError(f'fic_core must not import ROS, tried {name}')
        sys.meta_path.insert(0, NoRos())
        import fic_core
        for module in pkgutil.iter_modules(fic_core.__path__):
            importlib.import_module('fic_core.' + module.name)
        print('imported', len(list(pkgutil.iter_modules(fic_core.__path__))), 'modules')
        """
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "imported" in result.stdout


PUBLISHER = textwrap.dedent(
    """
    import sys, time
    import rclpy
    from fic_teleop_msgs.msg import TeleoperationCommand, FicState, LimitStatus, ChannelDelivery
    rclpy.init()
    node = rclpy.create_node('message_sender')
    command = TeleoperationCommand(mode=TeleoperationCommand.MODE_VELOCITY, haptic_gain=0.35,
                                   workspace_scale=1.5, velocity_gain=2.0)
    command.header.stamp.sec = 42; command.header.stamp.nanosec = 7; command.header.frame_id = 'haptic_base'
    command.handle_position.x = 0.01; command.desired_offset.z = -0.02
    state = FicState(controller='fic', phase=[0, 1, 0, 1, 1, 0], error=[0.1, -0.2, 0.3, 0.0, 0.01, -0.01],
                     latched_max_error=[0.0, 0.25, 0.0, 0.0, 0.02, 0.0], force=[1.0] * 6,
                     stored_energy=[0.5] * 6, total_energy=3.25, master_age=0.2, master_stale=True)
    state.master_stamp.sec = 41
    limits = LimitStatus(shaping=LimitStatus.TORQUE | LimitStatus.TCP_SPEED, violations=0, torque_change=1.5,
                         torque_ratio=[0.1] * 7, torque_rate_ratio=[0.2] * 7, joint_velocity_ratio=[0.3] * 7,
                         joint_position_margin=[0.4] * 7, tcp_speed=1.2)
    delivery = ChannelDelivery(topic='/replica/teleop_command', held=0.2)
    delivery.header.stamp.sec = 42; delivery.received.sec = 43
    publishers = [(node.create_publisher(type(m), '/roundtrip/' + type(m).__name__, 10), m)
                  for m in (command, state, limits, delivery)]
    deadline = time.monotonic() + float(sys.argv[1])
    while time.monotonic() < deadline:
        for publisher, message in publishers:
            publisher.publish(message)
        time.sleep(0.05)
    node.destroy_node(); rclpy.shutdown()
    """
)


@pytest.mark.nodes
def test_messages_round_trip_between_processes(ros_env, rclpy_context, tmp_path) -> None:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from fic_teleop_msgs.msg import ChannelDelivery, FicState, LimitStatus, TeleoperationCommand

    sender = subprocess.Popen([sys.executable, "-c", PUBLISHER, "20"], env=ros_env,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        node = rclpy.create_node("message_receiver", context=rclpy_context)
        received: dict[str, object] = {}
        for message_type in (TeleoperationCommand, FicState, LimitStatus, ChannelDelivery):
            node.create_subscription(message_type, "/roundtrip/" + message_type.__name__,
                                     lambda message: received.setdefault(type(message).__name__, message), 10)
        executor = SingleThreadedExecutor(context=rclpy_context)
        executor.add_node(node)
        deadline = time.monotonic() + 20
        while len(received) < 4 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        assert len(received) == 4, f"received only {sorted(received)}; sender said {sender.stdout}"
    finally:
        sender.kill()
        sender.wait()

    command = received["TeleoperationCommand"]
    assert command.mode == TeleoperationCommand.MODE_VELOCITY == 1
    assert command.haptic_gain == pytest.approx(0.35) and command.workspace_scale == pytest.approx(1.5)
    assert command.header.stamp.sec == 42 and command.header.stamp.nanosec == 7
    assert command.handle_position.x == pytest.approx(0.01) and command.desired_offset.z == pytest.approx(-0.02)
    state = received["FicState"]
    assert list(state.phase) == [0, 1, 0, 1, 1, 0] and state.controller == "fic"
    assert list(state.latched_max_error)[1] == pytest.approx(0.25) and state.master_stale
    assert state.master_stamp.sec == 41 and state.total_energy == pytest.approx(3.25)
    limits = received["LimitStatus"]
    assert limits.shaping == LimitStatus.TORQUE | LimitStatus.TCP_SPEED == 17
    assert len(limits.joint_position_margin) == 7 and limits.tcp_speed == pytest.approx(1.2)
    delivery = received["ChannelDelivery"]
    assert delivery.topic == "/replica/teleop_command" and delivery.held == pytest.approx(0.2)
    assert delivery.header.stamp.sec == 42 and delivery.received.sec == 43
