"""When the replica's law runs: the control grid on joint-state time, and the rate gates of its status streams.

The control step is event-driven: it runs on a joint state (the simulator's realtime and lockstep modes alike).
With ``control_rate`` below the joint-state rate the law runs every 1/control_rate seconds of joint-state time
(half a command period of slack, so a state that arrives a little early still counts) and the torque is held in
between. ``tick_on_command``: a new teleoperation command also starts a tick at the next joint state, the grid
restarting from it (the command is applied up to one period sooner, at most one extra tick per command).

The interval handed to the law is the one between the joint-state stamps of two ticks: a busy replica skips
states, and x_d's velocity and the give-back of jumps must use the real interval, not the nominal one (a skipped
tick at the nominal dt doubled the velocity). A longer interval than ``MAX_CONTROL_INTERVAL_S`` (a stall, a
restart) counts as one nominal period, and none is shorter than half of one.
"""
from __future__ import annotations

from .errors import FicInputError, finite_scalar

#: A longer interval between two control ticks (a stall, a restart) is taken as one nominal period [s].
MAX_CONTROL_INTERVAL_S = 0.1


class RateGate:
    """Whether a stream at ``rate`` is due at time t (half a command period of slack; a time going back
    restarts it)."""

    def __init__(self, rate: float, command_period: float) -> None:
        self.rate = finite_scalar("rate", rate, minimum=0.0, minimum_inclusive=False)
        self.command_period = finite_scalar("command_period", command_period, minimum=0.0, minimum_inclusive=False)
        self.last: float | None = None

    def due(self, time: float) -> bool:
        last = self.last
        return last is None or time < last or time - last >= 1.0 / self.rate - 0.5 * self.command_period

    def take(self, time: float) -> bool:
        """``due``, and if so the stream's last time becomes ``time``."""
        if self.due(time):
            self.last = time
            return True
        return False


class ControlSchedule:
    """The control grid on joint-state time (module docstring)."""

    def __init__(self, control_rate: float, command_period: float, tick_on_command: bool = False) -> None:
        self._grid = RateGate(control_rate, command_period)
        if 1.0 / self._grid.rate < command_period * 0.999:
            raise FicInputError(f"control_rate {control_rate:g} Hz is faster than the joint states "
                                f"(command_period {command_period:g} s)")
        self.tick_on_command = bool(tick_on_command)

    @property
    def control_period(self) -> float:
        return 1.0 / self._grid.rate

    @property
    def command_period(self) -> float:
        return self._grid.command_period

    @property
    def last_tick(self) -> float | None:
        return self._grid.last

    def due(self, time: float, command_unused: bool = False) -> bool:
        """Whether the joint state stamped ``time`` starts a control tick; ``command_unused``: a teleoperation
        command no tick has used yet is waiting (counts only with tick_on_command)."""
        return self._grid.due(time) or (self.tick_on_command and command_unused)

    def tick(self, time: float) -> float:
        """Start a tick at ``time``: the interval since the last tick for the law (module docstring)."""
        last = self._grid.last
        period = self.control_period
        dt = time - last if last is not None and 0.0 < time - last <= MAX_CONTROL_INTERVAL_S else period
        self._grid.last = time
        return max(dt, 0.5 * period)

    def continue_from(self, other: ControlSchedule) -> None:
        """Keep another schedule's grid (a change of rate at run time does not restart the phase)."""
        self._grid.last = other._grid.last
