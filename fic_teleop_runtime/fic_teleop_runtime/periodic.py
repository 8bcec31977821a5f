"""Periodic callbacks on the node's clock: rclpy timers on wall time, and under simulated time callbacks that the
time source runs as each /clock message sets the time.

Why not a timer under simulated time: the EventsExecutor's timers do not follow /clock (docs/CONVENTIONS.md, "Time"),
and the wait-set executor that does costs a node 419 us of CPU a wake-up against 56 us (docs/RESULTS.md, "Graph
levers"); in lockstep /clock comes every physics step, 1,000 times a simulated second, and wakes every node that
follows it. Here the time source's own /clock callback runs the due callbacks through a clock jump callback, right
after it has set the time, whatever the executor; so a node whose timers are all made here spins the EventsExecutor
under simulated time too (NodeEntry.follow_sim_time=False).

The deadlines are an rcl timer's: the first one period after the callback is made (on the clock as it reads then),
then one period after the last deadline, and a deadline the clock has jumped past by more than a period is skipped,
not run late in a burst (rcl_timer_call).
"""
from __future__ import annotations

from collections.abc import Callable

from rclpy.clock import JumpThreshold
from rclpy.duration import Duration
from rclpy.node import Node

#: Every forward step of the simulated clock runs the due callbacks (the smallest positive threshold).
_EVERY_FORWARD_STEP = JumpThreshold(min_forward=Duration(nanoseconds=1), min_backward=None, on_clock_change=False)


class SimulatedTimer:
    """A periodic callback on simulated time (module docstring): cancel() stops it, as a timer's."""

    def __init__(self, period_ns: int, callback: Callable[[], None], now_ns: int) -> None:
        if period_ns <= 0:
            raise ValueError(f"period must be positive, got {period_ns} ns")
        self.period_ns = period_ns
        self._callback = callback
        self._next_ns = now_ns + period_ns
        self._canceled = False

    def cancel(self) -> None:
        self._canceled = True

    def is_canceled(self) -> bool:
        return self._canceled

    def due(self, now_ns: int) -> bool:
        """Whether a deadline has come at ``now_ns``; if so the next one is set (missed periods skipped)."""
        if self._canceled or now_ns < self._next_ns:
            return False
        self._next_ns += self.period_ns * ((now_ns - self._next_ns) // self.period_ns + 1)
        return True

    def run(self) -> None:
        self._callback()


class PeriodicCallbacks:
    """A node's periodic callbacks (module docstring). Keep it on the node: its jump handle lives as long as it."""

    def __init__(self, node: Node) -> None:
        self._node = node
        self._clock = node.get_clock()
        self.simulated = bool(node.get_parameter("use_sim_time").value)
        self._timers: list[SimulatedTimer] = []
        self._jump_handle = (self._clock.create_jump_callback(_EVERY_FORWARD_STEP, post_callback=self._time_set)
                             if self.simulated else None)

    def create(self, period_s: float, callback: Callable[[], None]):
        """Run ``callback`` every ``period_s`` seconds of the node's clock; returns a timer (``cancel()``)."""
        if not self.simulated:
            return self._node.create_timer(period_s, callback)
        timer = SimulatedTimer(round(period_s * 1e9), callback, self._clock.now().nanoseconds)
        self._timers.append(timer)
        return timer

    def _time_set(self, _jump) -> None:
        now_ns = self._clock.now().nanoseconds
        for timer in [timer for timer in self._timers if timer.due(now_ns)]:
            timer.run()
