"""Keys to operator commands for the terminal keyboard teleop (keyboard_operator.py), without any terminal or ROS.

Holding a key moves the hand target along one axis: terminals send a key's character again at the auto-repeat
rate while it is held and nothing on release, so an axis stays active for ``hold_time`` after its last repeat
(longer than the usual 250-600 ms auto-repeat delay) and then stops by itself. Buttons are one-shot presses.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from fic_teleop_runtime.episode_markers import DISCARD, FAILURE, KEEP, SUCCESS
from sim_bridge.device.virtual_operator import (
    BUTTON_COUNT,
    BUTTON_HAPTIC_GAIN_DOWN,
    BUTTON_HAPTIC_GAIN_UP,
    BUTTON_TOGGLE_MODE,
)

# Arrow keys arrive as ANSI escape sequences; they are decoded to these names first.
ARROWS = {"\x1b[A": "up", "\x1b[B": "down", "\x1b[C": "right", "\x1b[D": "left"}

# key -> (axis, direction). x forward/back, y left/right, z up/down (haptic_base axes).
MOTION_KEYS = {
    "w": (0, 1.0), "s": (0, -1.0), "up": (0, 1.0), "down": (0, -1.0),
    "a": (1, 1.0), "d": (1, -1.0), "left": (1, 1.0), "right": (1, -1.0),
    "r": (2, 1.0), "f": (2, -1.0),
}
BUTTON_KEYS = {"m": BUTTON_TOGGLE_MODE, "+": BUTTON_HAPTIC_GAIN_UP, "=": BUTTON_HAPTIC_GAIN_UP,
               "-": BUTTON_HAPTIC_GAIN_DOWN, "_": BUTTON_HAPTIC_GAIN_DOWN}
# The episode's markers (fic_teleop_runtime.episode_markers): keep or discard it, and whether it succeeded.
MARKER_KEYS = {"k": KEEP, "x": DISCARD, "y": SUCCESS, "n": FAILURE}
STOP_KEY = " "
QUIT_KEYS = ("q", "\x03")          # q, Ctrl-C (raw mode delivers it as a character, not a signal)

HELP = """\
fic_teleop keyboard operator  (publishes sensor_msgs/Joy on /operator/joy)
  w/s or Up/Down     hand target +x/-x        a/d or Left/Right  +y/-y
  r/f                +z/-z                     hold a key to keep moving, release to stop
  m                  toggle OFFSET/VELOCITY mode (the master keeps the mode)
  + / -              raise / lower the haptic gain K_H
  k / x              keep / discard this episode (the dataset export leaves a discarded one out)
  y / n              mark the episode a success / a failure
  space              stop all motion           q or Ctrl-C   quit
"""


def split_keys(data: str) -> list[str]:
    """Split raw terminal input into key names (arrow escape sequences become 'up', 'down', ...)."""
    keys = []
    index = 0
    while index < len(data):
        sequence = data[index:index + 3]
        if sequence in ARROWS:
            keys.append(ARROWS[sequence])
            index += 3
        else:
            keys.append(data[index].lower() if data[index].isalpha() else data[index])
            index += 1
    return keys


@dataclass
class KeyboardState:
    hold_time: float = 0.6                                   # [s] an axis stays on after its last key repeat
    axes: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    _last_press: list[float] = field(default_factory=lambda: [float("-inf")] * 3)
    _pending_buttons: list[int] = field(default_factory=list)
    _button_down: bool = False
    _pending_marks: list[str] = field(default_factory=list)
    quit: bool = False

    def press(self, key: str, now: float) -> None:
        if key in MOTION_KEYS:
            axis, direction = MOTION_KEYS[key]
            self.axes[axis] = direction
            self._last_press[axis] = now
        elif key in BUTTON_KEYS:
            self._pending_buttons.append(BUTTON_KEYS[key])
        elif key in MARKER_KEYS:
            self._pending_marks.append(MARKER_KEYS[key])
        elif key == STOP_KEY:
            self.axes = [0.0, 0.0, 0.0]
            self._last_press = [float("-inf")] * 3
        elif key in QUIT_KEYS:
            self.quit = True

    def sample(self, now: float) -> tuple[list[float], list[int]]:
        """Axes and buttons for the next Joy message: axes released after hold_time, at most one button press
        per message so that a press is always followed by a release (edge-triggered, like the scripted one)."""
        for axis in range(3):
            if now - self._last_press[axis] > self.hold_time:
                self.axes[axis] = 0.0
        buttons = [0] * BUTTON_COUNT
        if self._pending_buttons and not self._button_down:
            buttons[self._pending_buttons.pop(0)] = 1
            self._button_down = True
        else:
            self._button_down = False
        return list(self.axes), buttons

    def take_marks(self) -> list[str]:
        """The episode markers pressed since the last call, in order (each published once)."""
        marks, self._pending_marks = self._pending_marks, []
        return marks
