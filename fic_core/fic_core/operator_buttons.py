"""The operator's buttons (sensor_msgs/Joy indices on /operator/joy, docs/CONVENTIONS.md): the one map of them.

The paper's operator changes the haptic gain K_H online (Eq. 3; the Sigma.7's grasp DoF) and switches the
teleoperation mode (Sec. II-C). A press is edge-triggered: one message with the button at 1, then messages with
it at 0; ``ButtonEdges`` turns successive button states into the presses (rising edges) they contain.
"""
from __future__ import annotations

from collections.abc import Sequence
from enum import IntEnum


class OperatorButton(IntEnum):
    TOGGLE_MODE = 0        # OFFSET <-> VELOCITY
    HAPTIC_GAIN_UP = 1     # K_H + HAPTIC_GAIN_STEP
    HAPTIC_GAIN_DOWN = 2   # K_H - HAPTIC_GAIN_STEP


#: Button names as operator scripts write them.
BUTTON_NAMES: dict[str, OperatorButton] = {"toggle_mode": OperatorButton.TOGGLE_MODE,
                                            "haptic_gain_up": OperatorButton.HAPTIC_GAIN_UP,
                                            "haptic_gain_down": OperatorButton.HAPTIC_GAIN_DOWN}
BUTTON_COUNT = len(OperatorButton)
#: The change of K_H a press of HAPTIC_GAIN_UP or _DOWN makes.
HAPTIC_GAIN_STEP = 0.1


class ButtonEdges:
    """Rising edges of button states (a button missing from a shorter message counts as released)."""

    def __init__(self) -> None:
        self._previous: list[int] = []

    def pressed(self, buttons: Sequence[int]) -> set[int]:
        """The buttons that went from released to pressed since the last call."""
        buttons = list(buttons)
        previous = self._previous + [0] * max(0, len(buttons) - len(self._previous))
        self._previous = buttons
        return {index for index, state in enumerate(buttons) if state and not previous[index]}
