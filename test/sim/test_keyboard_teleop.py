"""Keys to operator commands (sim_bridge/device/keyboard_teleop.py), without a terminal."""
from sim_bridge.device.keyboard_teleop import KeyboardState, split_keys
from sim_bridge.device.virtual_operator import BUTTON_HAPTIC_GAIN_DOWN, BUTTON_TOGGLE_MODE


def test_arrow_sequences_and_letters_are_split_into_keys():
    assert split_keys("\x1b[Aw\x1b[DM+ ") == ["up", "w", "left", "m", "+", " "]


def test_a_held_key_keeps_its_axis_and_a_released_one_stops_after_the_hold_time():
    state = KeyboardState(hold_time=0.6)
    state.press("w", 0.0)
    state.press("d", 0.0)
    assert state.sample(0.5)[0] == [1.0, -1.0, 0.0]
    state.press("w", 0.5)                      # auto-repeat of w only
    assert state.sample(0.9)[0] == [1.0, 0.0, 0.0]
    assert state.sample(1.2)[0] == [0.0, 0.0, 0.0]
    state.press("r", 2.0)
    state.press(" ", 2.1)                      # space stops at once
    assert state.sample(2.1)[0] == [0.0, 0.0, 0.0]


def test_button_presses_are_one_message_each_with_a_release_between():
    state = KeyboardState()
    for key in "mm-":
        state.press(key, 0.0)
    pressed = [state.sample(0.0)[1] for _ in range(6)]
    assert [b.index(1) if 1 in b else None for b in pressed] == [
        BUTTON_TOGGLE_MODE, None, BUTTON_TOGGLE_MODE, None, BUTTON_HAPTIC_GAIN_DOWN, None]


def test_q_and_ctrl_c_quit():
    for key in ("q", "\x03"):
        state = KeyboardState()
        state.press(key, 0.0)
        assert state.quit


def test_episode_keys_are_markers_taken_once_in_order_and_move_nothing():
    state = KeyboardState()
    for key in "kyXn":
        state.press(key.lower() if key.isalpha() else key, 0.0)
    axes, buttons = state.sample(0.0)
    assert axes == [0.0, 0.0, 0.0] and 1 not in buttons
    assert state.take_marks() == ["keep", "success", "discard", "failure"]
    assert state.take_marks() == []
