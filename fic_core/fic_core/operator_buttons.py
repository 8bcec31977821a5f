"""The operator's buttons (sensor_msgs/Joy indices on /operator/joy, docs/CONVENTIONS.md): the one map of them.

The paper's operator changes the haptic gain K_H online (Eq. 3; the Sigma.7's grasp DoF) and switches the
teleoperation mode (Sec. II-C). A press is edge-triggered: one message with the button at 1, then messages with
it at 0; ``ButtonEdges`` turns successive button states into the presses (rising edges) and releases (falling
edges) they contain. The clutch is held: pressing it holds x_d' still while the handle moves (indexing), releasing
it engages the handle again (fic_core.master_station; a Force Dimension device's button or clutch maps to it,
fic_teleop_master's fd_adapter_node).
"""
from __future__ import annotations

from collections.abc import Sequence
from enum import IntEnum


class OperatorButton(IntEnum):
    TOGGLE_MODE = 0        # OFFSET <-> VELOCITY
    HAPTIC_GAIN_UP = 1     # K_H + HAPTIC_GAIN_STEP
    HAPTIC_GAIN_DOWN = 2   # K_H - HAPTIC_GAIN_STEP
    CLUTCH = 3             # held: x_d' holds still while the handle moves; released: engaged again, re-anchored


#: Button names as operator scripts write them.
BUTTON_NAMES: dict[str, OperatorButton] = {"toggle_mode": OperatorButton.TOGGLE_MODE,
                                            "haptic_gain_up": OperatorButton.HAPTIC_GAIN_UP,
                                            "haptic_gain_down": OperatorButton.HAPTIC_GAIN_DOWN,
                                            "clutch": OperatorButton.CLUTCH}
BUTTON_COUNT = len(OperatorButton)
#: The change of K_H a press of HAPTIC_GAIN_UP or _DOWN makes.
HAPTIC_GAIN_STEP = 0.1


class ButtonEdges:
    """Edges of button states (a button missing from a shorter message counts as released)."""

    def __init__(self) -> None:
        self._previous: list[int] = []

    def changes(self, buttons: Sequence[int]) -> tuple[set[int], set[int]]:
        """(pressed, released): the buttons that went from released to pressed, and back, since the last call."""
        buttons = list(buttons)
        count = max(len(buttons), len(self._previous))
        previous = self._previous + [0] * (count - len(self._previous))
        now = buttons + [0] * (count - len(buttons))
        self._previous = buttons
        return ({index for index in range(count) if now[index] and not previous[index]},
                {index for index in range(count) if previous[index] and not now[index]})

    def pressed(self, buttons: Sequence[int]) -> set[int]:
        """The buttons that went from released to pressed since the last call."""
        return self.changes(buttons)[0]
