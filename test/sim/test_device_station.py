"""The device station (sim_bridge/device/device_station.py): the simulated device with the operator's hand, as the
device node and the in-process runner step it: the force command's freshness, the script's clock and buttons, the
edge-triggered presses, the force-reactive hand feeling the rendered force, a driver that holds the last force."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from sim_bridge.device.device_station import DeviceStation
from sim_bridge.device.haptic_device import HapticDevice
from sim_bridge.device.reactive_hand import ReactiveHand, ReactiveHandParameters
from sim_bridge.device.virtual_operator import Hand, HandParameters, ScriptedOperator, ScriptEvent, load_script

SCRIPT = Path(__file__).resolve().parents[2] / "config" / "operator_scripts" / "free_space.yaml"
DT = 0.004


def test_a_stale_command_renders_zero_said_once_and_a_fresh_one_ends_it() -> None:
    station = DeviceStation(HapticDevice(), Hand(HandParameters()), command_timeout=0.02)
    assert not station.update(0.0, 0.0).command.any()            # no command yet: zero, and nothing to say
    assert not station.command([1.0, 0.0, 0.0], 0.004)
    step = station.update(0.008, DT)
    assert step.command.tolist() == [1.0, 0.0, 0.0] and not step.stale_now
    stale = [station.update(0.008 + DT * k, DT) for k in range(1, 10)]
    assert sum(s.stale_now for s in stale) == 1 and not stale[-1].command.any()
    assert station.command([2.0, 0.0, 0.0], 0.05)                # ends the stale period


def test_a_driver_that_holds_the_last_force_never_goes_stale() -> None:
    station = DeviceStation(HapticDevice(), Hand(HandParameters()), command_timeout=None)
    station.command([0.0, 1.0, 0.0], 0.0)
    step = station.update(100.0, DT)
    assert step.command.tolist() == [0.0, 1.0, 0.0] and not step.stale_now


def test_the_script_drives_the_hand_on_its_own_clock_and_its_presses_come_one_at_a_time() -> None:
    script = load_script(SCRIPT)
    origin = 0.5
    station = DeviceStation(HapticDevice(), Hand(HandParameters()), script=ScriptedOperator(script),
                            command_timeout=0.02, script_origin=origin)
    end = script.duration + origin + 0.1
    presses, now = [], 0.0
    while now < end:
        station.update(now, DT if now else 0.0)
        np.testing.assert_allclose(station.target, script.target(max(now - origin, 0.0)))
        if round(now / DT) % 5 == 0:   # the 50 Hz button timer
            presses.append(station.press())
        now += DT
    pressed = [button for button in presses if button is not None]
    assert pressed == [event.button for event in script.events]
    # Edge-triggered: a press is followed by a tick with all released.
    assert all(not (a is not None and b is not None) for a, b in zip(presses, presses[1:]))


def test_a_joy_message_is_due_only_at_a_press_and_its_release() -> None:
    """The node publishes what button_states returns: each scripted press as one message with that button down,
    the next tick's release, and nothing on the ticks in between (the master reads rising edges)."""
    script = dataclasses.replace(load_script(SCRIPT), events=(   # two presses of one button in a row, and another
        ScriptEvent(0.5, 0), ScriptEvent(0.5, 0), ScriptEvent(1.2, 1)))
    station = DeviceStation(HapticDevice(), Hand(HandParameters()), script=ScriptedOperator(script),
                            command_timeout=0.02, script_origin=0.0)
    messages, now, ticks = [], 0.0, 0
    while now < script.duration + 0.1:
        station.update(now, DT if now else 0.0)
        if round(now / DT) % 5 == 0:   # the 50 Hz button timer
            ticks += 1
            buttons = station.button_states()
            if buttons is not None:
                messages.append(buttons)
        now += DT
    presses = [message.index(1) for message in messages if any(message)]
    assert presses == [event.button for event in script.events] and presses
    assert messages == [state for button in presses for state in
                        ([1 if index == button else 0 for index in range(len(messages[0]))], [0] * len(messages[0]))]
    assert len(messages) == 2 * len(presses) < ticks / 10


def test_the_reactive_hand_feels_the_force_the_motors_render() -> None:
    device = HapticDevice()
    hand = ReactiveHand(HandParameters(), ReactiveHandParameters())
    station = DeviceStation(device, hand, script=ScriptedOperator(load_script(SCRIPT)), command_timeout=0.02)
    station.command([0.0, 0.0, 50.0], 0.0)   # beyond the device's saturation
    felt = []
    original = hand.update

    def spy(target, position, dt, velocity=None, rendered=None):
        felt.append(None if rendered is None else np.array(rendered))
        return original(target, position, dt, velocity, rendered)

    hand.update = spy
    station.update(0.004, DT)
    np.testing.assert_allclose(felt[-1], device.saturate(np.array([0.0, 0.0, 50.0])))
