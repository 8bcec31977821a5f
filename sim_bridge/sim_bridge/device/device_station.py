"""The simulated haptic device with the operator's hand on it, one step at a time: what haptic_device_node runs at
its publish rate and the in-process runner steps.

    force command (Eq. 3, from the master) --> fresh? (command_timeout; a forcedimension driver holds it forever)
    operator: a script (its clock from script_origin), the closed-loop operator of E1 or the shape-sorting operator
        of E2 (they watch the delayed video), joystick axes, or none --> the hand's target
    the hand (virtual_operator.Hand, or the force-reactive hand, which feels the rendered force) --> hand force
    HapticDevice.step(command, hand force, dt) --> the handle's pose and twist x_M
    the operator's button presses --> a queue, pressed one at a time by the caller's button timer (``press``)

From ``quiet_from`` on (a run's quiet tail, docs/EXPERIMENTS.md "The run verdict") the operator stops: the hand's
target holds where it was and no button is pressed, while the hand keeps holding the handle (a reactive hand keeps
answering the force it feels) and the device keeps rendering the master's force.

The caller gives the clock (``now``) and the step (``dt``); the video frames go to the watching operator directly
(``watcher.see``), the logging of its moves to the caller (``DeviceStep.moves``).
"""
from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sim_bridge.device.closed_loop_operator import ClosedLoopOperator
from sim_bridge.device.haptic_device import HapticDevice, HapticDeviceState
from sim_bridge.device.reactive_hand import ReactiveHand
from sim_bridge.device.shape_sorting_operator import ShapeSortingOperator
from sim_bridge.device.virtual_operator import BUTTON_COUNT, Hand, JoyTarget, ScriptedOperator


@dataclass
class DeviceStep:
    state: HapticDeviceState                 # the handle after the step (x_M, its velocity)
    command: NDArray[np.float64]          # the force command applied (zero while stale)
    stale_now: bool = False               # the command turned stale at this step (say so once)
    moves: list[tuple] = field(default_factory=list)   # the watching operator's moves begun at this step


class DeviceStation:
    """A HapticDevice, the operator's hand and what drives it (module docstring). ``watcher``: the closed-loop or the
    shape-sorting operator (the latter presses its own buttons, the former the script's); ``command_timeout``: None
    for a driver that holds the last force forever (forcedimension_ros2's forward controller)."""

    def __init__(self, device: HapticDevice, hand: Hand, *, script: ScriptedOperator | None = None,
                 watcher: ClosedLoopOperator | ShapeSortingOperator | None = None,
                 joy_target: JoyTarget | None = None, command_timeout: float | None = None,
                 joy_timeout: float = 0.5, script_origin: float = 0.0, quiet_from: float | None = None) -> None:
        self.device = device
        self.hand = hand
        self.script = script
        self.watcher = watcher
        self.sorter = watcher if isinstance(watcher, ShapeSortingOperator) else None
        self.joy_target = joy_target
        self.command_timeout = command_timeout
        self.joy_timeout = joy_timeout
        self.script_origin = script_origin
        self.quiet_from = quiet_from
        self.command_force = np.zeros(3)
        self.command_time: float | None = None
        self.stale = False
        self.buttons: deque[int] = deque()   # presses waiting for the button timer
        self._button_down = False
        self.target: NDArray[np.float64] = np.zeros(3)   # the hand's last target [m]
        self._axes: list[float] = []
        self._axes_time = -np.inf

    # --- inputs ----------------------------------------------------------------------------------------------
    def command(self, force: ArrayLike, now: float) -> bool:
        """A force command at ``now`` (the caller refuses non-finite ones); whether it ends a stale period."""
        self.command_force = np.asarray(force, dtype=float)
        self.command_time = now
        ended, self.stale = self.stale, False
        return ended

    def axes(self, axes: Sequence[float], now: float) -> None:
        """Joystick axes 0..2 at ``now`` (they steer the hand's target while younger than joy_timeout)."""
        self._axes, self._axes_time = list(axes), now

    def fresh(self, now: float) -> bool:
        if self.command_time is None:
            return False
        return self.command_timeout is None or now - self.command_time <= self.command_timeout

    # --- the step --------------------------------------------------------------------------------------------
    def update(self, now: float, dt: float) -> DeviceStep:
        """The operator and the handle over ``dt`` up to ``now``."""
        fresh = self.fresh(now)
        stale_now = not fresh and self.command_time is not None and not self.stale
        self.stale = self.stale or stale_now
        command = self.command_force if fresh else np.zeros(3)
        device, hand, watcher = self.device, self.hand, self.watcher
        script_time = max(now - self.script_origin, 0.0)
        moves_before = len(watcher.moves_started) if watcher is not None else 0
        quiet = self.quiet_from is not None and now >= self.quiet_from
        if quiet:   # the quiet tail: the target held, no operator asked (module docstring)
            target = self.target if self.watcher is not None or self.script is not None \
                or self.joy_target is not None else None
        elif watcher is not None:
            target = watcher.target(now)
        elif self.script is not None:
            target = self.script.target(script_time)
        elif self.joy_target is not None:
            target = self.joy_target.update(self._axes if now - self._axes_time <= self.joy_timeout else [], dt)
        else:
            target = None
        reactive = isinstance(hand, ReactiveHand)
        if self.sorter is not None or reactive:   # the force the motors render on the handle: what the hand feels
            rendered = device.saturate(self.command_force) if fresh else np.zeros(3)
        if self.sorter is not None:
            self.sorter.feel(rendered, device.position)
        if target is None:
            hand_force = np.zeros(3)
        else:
            self.target = target
            if reactive:
                hand.update(target, device.position, dt, device.velocity, rendered)
            else:
                hand.update(target, device.position, dt)
            hand_force = hand.force
        if self.sorter is not None and not quiet:
            self.buttons.extend(event.button for event in self.sorter.poll_events(now))
        elif self.script is not None and not quiet:
            self.buttons.extend(event.button for event in self.script.poll_events(script_time))
        state = device.step(command, hand_force, dt)
        moves = list(watcher.moves_started[moves_before:]) if watcher is not None else []
        return DeviceStep(state, command, stale_now, moves)

    @property
    def handle_kinetic_energy(self) -> float:
        """1/2 m_h |v_M|^2 of the handle now [J]."""
        velocity = self.device.velocity
        return 0.5 * self.device.parameters.mass * float(velocity @ velocity)

    def press(self, skip_first: bool = False) -> int | None:
        """At a button tick: the button to press now, or None (edge-triggered: a press, then a tick with all
        released, so two presses of one button in a row stay two). ``skip_first``: the first waiting press is
        not this timer's (the forcedimension device's own button carries it)."""
        if not self._button_down and self.buttons and not (skip_first and self.buttons[0] == 0):
            self._button_down = True
            return self.buttons.popleft()
        self._button_down = False
        return None

    def button_states(self, skip_first: bool = False) -> list[int] | None:
        """At a button tick: the buttons a Joy message carries now (one pressed, or all released after a press), or
        None when nothing changed since the last (no press waiting, none to release). The master reads rising edges,
        so a message is needed only at a change: a Joy every 20 ms with nothing pressed was 50 messages a second to
        the master and the recorder."""
        was_down = self._button_down
        button = self.press(skip_first)
        if button is None and not was_down:
            return None
        states = [0] * BUTTON_COUNT
        if button is not None:
            states[button] = 1
        return states


__all__ = ["DeviceStation", "DeviceStep"]
