"""The torque-command relay's watchdog: what the arm receives when the replica stops sending.

ros2_control's forward command controller (franka_ros2's effort controller) applies the last torque it received for
as long as nobody sends another, so a replica process that dies, hangs or loses its host leaves its last command on
a real arm (docs/HARDWARE.md, "Watchdogs"). The relay stands between the two: it forwards every replica command
unchanged (the torque fic_core checked against the limits is the torque sent) and, when none has come for
``timeout``, sends a command that moves linearly over ``ramp_time`` from the last one to the rest command
(fic_core.stale_input_ramp, the same ramp the replica applies when its joint states stop) and holds it: zero when
the arm compensates its own gravity (it then floats, as in Franka's gravity-compensation example), G(q) at the
last joint state otherwise (fic_core.torque_semantics). The ramp's rate is at most twice the largest joint torque
over ``ramp_time``. The replica's next command ends the ramp and is forwarded as it is.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_array
from .stale_input_ramp import StaleInputRamp
from .torque_semantics import TorqueSemantics


class CommandWatchdog:
    """Forwards replica torque commands and ramps to the rest command once they stop (module docstring)."""

    def __init__(self, timeout: float, ramp_time: float, semantics: TorqueSemantics) -> None:
        self.ramp = StaleInputRamp(timeout, ramp_time)
        self.semantics = semantics
        self.last_command: NDArray[np.float64] | None = None
        self.forwarded = 0
        self.ramp_commands = 0

    def replica_command(self, values: ArrayLike, now: float) -> tuple[NDArray[np.float64], bool]:
        """A command of the replica at ``now``: the command to forward (unchanged) and whether it ends a ramp.
        A non-finite or empty command is refused (FicInputError): the last good one, or the ramp, stays."""
        command = finite_array("torque command", values)
        if command.ndim != 1 or command.size == 0:
            raise FicInputError(f"a torque command is a non-empty list of joint torques, got shape {command.shape}")
        if self.last_command is not None and command.shape != self.last_command.shape:
            raise FicInputError(f"torque command of {command.size} joints after {self.last_command.size}")
        ended = self.ramp.fresh(now)
        self.last_command = command
        self.forwarded += 1
        return command, ended

    def check(self, now: float, gravity: NDArray[np.float64] | None) -> tuple[NDArray[np.float64] | None, bool]:
        """At a timer tick: the ramp's command to send (None while the replica's commands are fresh) and whether
        the replica went silent at this tick (say so once). ``gravity``: G(q) at the last joint state, needed only
        when the arm does not compensate gravity itself (without it the last command is held)."""
        started = self.ramp.check(now, self.last_command)
        if not self.ramp.stale or self.last_command is None:
            return None, started
        if self.semantics.gravity_compensated_by_robot:
            rest = np.zeros_like(self.last_command)
        elif gravity is not None and gravity.shape == self.last_command.shape:
            rest = self.semantics.rest_command(gravity)
        else:
            rest = self.last_command
        self.ramp_commands += 1
        return self.ramp.command(now, rest), started
