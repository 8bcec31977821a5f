"""Terminal keyboard teleop (like teleop_twist_keyboard): keys to sensor_msgs/Joy on /operator/joy at 50 Hz.

axes[0..2] steer the virtual operator's hand target (haptic_device_node with operator_source:=joy); buttons
toggle the teleoperation mode and raise/lower K_H (read by the master); the episode keys publish markers on
/episode/marker (fic_teleop_runtime.episode_markers), which the recorder records and the dataset export honours.
The key logic is keyboard_teleop.py; this file owns the terminal (raw mode, restored on every exit path) and the
ROS wiring.
"""
from __future__ import annotations

import os
import select
import sys
import termios
import tty

import rclpy
from rclpy.node import Node
from sensor_msgs.msg import Joy
from std_msgs.msg import String

from fic_core.parameter_row import parameter_set
from fic_teleop_runtime import qos
from fic_teleop_runtime.episode_markers import MARKER_TOPIC
from fic_teleop_runtime.node_main import run_node
from fic_teleop_runtime.parameters import Schema, declare, number
from sim_bridge.device.keyboard_teleop import HELP, KeyboardState, split_keys

# Same QoS as the scripted operator's buttons: a lost toggle would invert the mode for the rest of the run.
JOY_QOS = qos.EVENTS
SCHEMA = Schema("keyboard_operator.yaml",
                number("rate_hz", 1.0, 500.0, "Joy publishing rate [Hz]"),
                number("hold_time", 0.05, 5.0, "an axis stays on this long after the key's last auto-repeat [s]"))
#: The keyboard operator's parameters as one typed object, one field a row of SCHEMA (fic_core.parameter_row): a name
#: no row has is refused where it is built, naming the nearest.
KeyboardOperatorParameters = parameter_set("KeyboardOperatorParameters", __name__, "keyboard operator", SCHEMA.rows,
                                           "The keyboard operator's parameters (SCHEMA), checked, one field a row.")
MODE_NAMES = ("OFFSET", "VELOCITY")


class KeyboardOperator(Node):
    def __init__(self, stdin_fd: int) -> None:
        super().__init__("keyboard_operator")
        # Every row with its config/keyboard_operator.yaml value (unknown keys refused), as one typed object.
        p = KeyboardOperatorParameters.from_values(declare(self, SCHEMA))
        self.fd = stdin_fd
        self.state = KeyboardState(hold_time=p.hold_time)
        self.mode = 0                  # what the master should be in if it started in OFFSET (display only)
        self.gain_presses = 0
        self.last_mark = "none"
        self.publisher = self.create_publisher(Joy, "/operator/joy", JOY_QOS)
        self.marker_publisher = self.create_publisher(String, MARKER_TOPIC, qos.MARKERS)
        self.create_timer(1.0 / p.rate_hz, self._tick)

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
        for mark in self.state.take_marks():
            self.marker_publisher.publish(String(data=mark))
            self.last_mark = mark
        sys.stdout.write(f"\r axes x {axes[0]:+.0f} y {axes[1]:+.0f} z {axes[2]:+.0f} | mode (if the master "
                         f"started in OFFSET) {MODE_NAMES[self.mode]:8s} | K_H presses {self.gain_presses:+d} | "
                         f"episode {self.last_mark:7s}   ")
        sys.stdout.flush()


def main(args: list[str] | None = None) -> None:
    if not sys.stdin.isatty():
        print("keyboard_operator needs an interactive terminal (stdin is not a TTY): run it in its own terminal, "
              "not under a launcher or a pipe.", file=sys.stderr)
        raise SystemExit(1)
    fd = sys.stdin.fileno()
    saved = termios.tcgetattr(fd)

    def make_node() -> KeyboardOperator:
        # The parameters first: a refused start is its one line, not a help text and a line after it.
        node = KeyboardOperator(fd)
        # cbreak: keys arrive one at a time without Enter, and Ctrl-C still raises SIGINT.
        tty.setcbreak(fd)
        print(HELP)
        return node

    try:
        run_node(make_node, "keyboard_operator", args)
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)
        print("\nkeyboard operator stopped, terminal restored.")


if __name__ == "__main__":
    main()
