"""Terminal keyboard teleop (like teleop_twist_keyboard): keys to sensor_msgs/Joy on /operator/joy at 50 Hz.

axes[0..2] steer the virtual operator's hand target (haptic_device_node with operator_source:=joy); buttons
toggle the teleoperation mode and raise/lower K_H (read by the master). The key logic is keyboard_teleop.py;
this file owns the terminal (raw mode, restored on every exit path) and the ROS wiring.
"""
from __future__ import annotations

import os
import select
import sys
import termios
import tty

import rclpy
from rclpy.signals import SignalHandlerOptions
from sim_bridge import stop_signals
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Joy

from sim_bridge.device.keyboard_teleop import HELP, KeyboardState, split_keys
from sim_bridge.spin import spin_until_shutdown

# Same QoS as the scripted operator's buttons: a lost toggle would invert the mode for the rest of the run.
JOY_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=50)
MODE_NAMES = ("OFFSET", "VELOCITY")


class KeyboardOperator(Node):
    def __init__(self, stdin_fd: int) -> None:
        super().__init__("keyboard_operator")
        self.declare_parameter("rate_hz", 50.0, ParameterDescriptor(
            description="Joy publishing rate [Hz]", floating_point_range=[
                FloatingPointRange(from_value=1.0, to_value=500.0, step=0.0)]))
        self.declare_parameter("hold_time", 0.6, ParameterDescriptor(
            description="an axis stays on this long after the key's last auto-repeat [s]", floating_point_range=[
                FloatingPointRange(from_value=0.05, to_value=5.0, step=0.0)]))
        self.fd = stdin_fd
        self.state = KeyboardState(hold_time=self.get_parameter("hold_time").value)
        self.mode = 0                  # what the master should be in if it started in OFFSET (display only)
        self.gain_presses = 0
        self.publisher = self.create_publisher(Joy, "/operator/joy", JOY_QOS)
        self.create_timer(1.0 / self.get_parameter("rate_hz").value, self._tick)

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _tick(self) -> None:
        now = self._now()
        while select.select([self.fd], [], [], 0.0)[0]:
            data = os.read(self.fd, 64).decode(errors="ignore")
            if not data:
                self.state.quit = True
                break
            for key in split_keys(data):
                self.state.press(key, now)
        if self.state.quit:
            rclpy.try_shutdown(context=self.context)
            return
        axes, buttons = self.state.sample(now)
        if buttons[0]:
            self.mode = 1 - self.mode
        self.gain_presses += buttons[1] - buttons[2]
        message = Joy()
        message.header.stamp = self.get_clock().now().to_msg()
        message.axes = [float(a) for a in axes]
        message.buttons = buttons
        self.publisher.publish(message)
        sys.stdout.write(f"\r axes x {axes[0]:+.0f} y {axes[1]:+.0f} z {axes[2]:+.0f} | mode (if the master "
                         f"started in OFFSET) {MODE_NAMES[self.mode]:8s} | K_H presses {self.gain_presses:+d}   ")
        sys.stdout.flush()


def main(args: list[str] | None = None) -> None:
    if not sys.stdin.isatty():
        print("keyboard_operator needs an interactive terminal (stdin is not a TTY): run it in its own terminal, "
              "not under a launcher or a pipe.", file=sys.stderr)
        raise SystemExit(1)
    fd = sys.stdin.fileno()
    saved = termios.tcgetattr(fd)
    stop_signals.install()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)  # our handlers: stop_signals.py
    node = None
    try:
        # cbreak: keys arrive one at a time without Enter, and Ctrl-C still raises SIGINT for rclpy.
        tty.setcbreak(fd)
        print(HELP)
        node = KeyboardOperator(fd)
        spin_until_shutdown(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)
        print("\nkeyboard operator stopped, terminal restored.")
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
