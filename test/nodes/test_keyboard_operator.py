"""The keyboard operator in a pseudo-terminal: keys become Joy messages; q quits and restores the terminal;
without a TTY it refuses to start with a clear message, and so it does, in one line, with a misspelt or
out-of-range parameter."""
from __future__ import annotations

import os
import pty
import select
import subprocess
import sys
import termios
import time
from pathlib import Path

import pytest

rclpy = pytest.importorskip("rclpy")
from rclpy.experimental import EventsExecutor  # noqa: E402
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import Joy  # noqa: E402

pytestmark = pytest.mark.nodes
QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=50)


def _env(tmp_path: Path, ros_env: dict[str, str]) -> dict[str, str]:
    env = dict(os.environ, ROS_DOMAIN_ID=ros_env["ROS_DOMAIN_ID"], ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               ROS_LOG_DIR=str(tmp_path / "ros_log"), PYTHONUNBUFFERED="1")
    return env


def test_without_a_tty_it_exits_with_a_clear_message(tmp_path, ros_env):
    result = subprocess.run([sys.executable, "-m", "sim_bridge.device.keyboard_operator"], env=_env(tmp_path, ros_env),
                            stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60)
    assert result.returncode == 1 and "not a TTY" in result.stderr


def test_keys_become_joy_messages_and_q_restores_the_terminal(tmp_path, ros_env):
    env = _env(tmp_path, ros_env)
    master, slave = pty.openpty()
    before = termios.tcgetattr(slave)
    process = subprocess.Popen([sys.executable, "-m", "sim_bridge.device.keyboard_operator"], env=env, stdin=slave,
                               stdout=slave, stderr=slave, close_fds=True)
    saved = {key: os.environ.get(key) for key in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOG_DIR")}
    os.environ.update({key: env[key] for key in saved})
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("joy_probe", context=context)
    executor = EventsExecutor(context=context)
    executor.add_node(node)
    messages: list[Joy] = []
    node.create_subscription(Joy, "/operator/joy", messages.append, QOS)

    output = b""

    def drain(timeout: float = 0.0) -> None:
        """Read what the operator wrote so far (waiting up to ``timeout`` for each more). Its status line goes out
        at 50 Hz, and a pseudo-terminal holds only a few kB: unread, it filled in 2-4 s here and blocked the
        operator in its write, before it read the q (the test then saw no exit on a loaded machine, where the first
        Joy message comes late)."""
        nonlocal output
        while select.select([master], [], [], timeout)[0]:
            try:
                chunk = os.read(master, 4096)
            except OSError:  # the slave side closed: the process is gone
                return
            if not chunk:
                return
            output += chunk

    def spin_for(seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.01)
            drain()

    try:
        deadline = time.monotonic() + 30.0
        while not messages and time.monotonic() < deadline:
            assert process.poll() is None
            spin_for(0.1)
        assert messages, "no Joy message"
        assert list(messages[-1].axes) == [0.0, 0.0, 0.0]
        os.write(master, b"w")
        spin_for(0.3)
        assert list(messages[-1].axes) == [1.0, 0.0, 0.0]
        os.write(master, b" m")
        spin_for(0.3)
        assert list(messages[-1].axes) == [0.0, 0.0, 0.0]
        assert sum(m.buttons[0] for m in messages) == 1
        os.write(master, b"q")
        deadline = time.monotonic() + 15.0
        while process.poll() is None and time.monotonic() < deadline:
            drain()
            time.sleep(0.02)
        code = process.wait(timeout=1.0)
        drain(timeout=0.2)  # its last lines may still be on their way through the pty
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
        if process.poll() is None:
            process.kill()
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
    assert code == 0
    assert b"keyboard operator" in output and b"terminal restored" in output
    assert termios.tcgetattr(slave)[3] == before[3]      # local modes (echo, canonical) as before
    os.close(master)
    os.close(slave)


@pytest.mark.parametrize("rule, complaint", [
    ("hold_tim:=0.2", "unknown parameter 'hold_tim' for node keyboard_operator; did you mean 'hold_time'?"),
    ("rate_hz:=1000.0", "rate_hz out of range")])
def test_a_bad_parameter_is_refused_in_one_line(rule, complaint, tmp_path, ros_env):
    """Refused before the help text and the cbreak mode: exit 2, one FATAL line, the terminal as it was."""
    master, slave = pty.openpty()
    before = termios.tcgetattr(slave)
    process = subprocess.Popen([sys.executable, "-m", "sim_bridge.device.keyboard_operator", "--ros-args", "-p",
                                rule], env=_env(tmp_path, ros_env), stdin=slave, stdout=slave, stderr=slave,
                               close_fds=True)
    output = b""
    try:
        code = process.wait(timeout=60)
        while select.select([master], [], [], 0.2)[0]:
            chunk = os.read(master, 4096)
            if not chunk:
                break
            output += chunk
    finally:
        if process.poll() is None:
            process.kill()
    text = output.decode(errors="replace")
    fatal = [line for line in text.splitlines() if "FATAL" in line]
    assert code == 2 and len(fatal) == 1 and "cannot start" in fatal[0] and complaint in fatal[0], text
    assert "Traceback" not in text and "terminal restored" in text and "hold a key to keep moving" not in text
    assert termios.tcgetattr(slave)[3] == before[3]
    os.close(master)
    os.close(slave)
