"""x_d' rebuilt between the link's samples at the replica's control rate, for any link rate from 1 kHz to 5 Hz.

The master samples x_d' at 100 Hz; a rate-capped link delivers every N-th sample and holds it (10 Hz: one sample in
ten). The replica runs its law at 0.5-1 kHz, so between two samples it must decide where x_d' is, how fast it moves
and how it accelerates, the last for the inertial feedforward J^T Lambda a_d (fic_core.replica). A hold whose
velocity and acceleration stop a fixed few milliseconds after each sample (fic_core.set_point's first-order hold,
made for the 100 Hz stream) silently turns that feedforward off at low rates: at 10 Hz it acted on 7.5 % of the
control ticks, and the arm swung 1.7 times its command near 0.6 Hz (docs/CONTROL_LAWS.md, "Low-rate links").

``LinkHold`` learns the link's sample interval T from the samples' stamps (the median of the last
``INTERVAL_WINDOW`` intervals, so a lost sample or a jittered one does not move it) and rebuilds x_d' over the whole
interval, in one of two designs (compared in docs/CONTROL_LAWS.md):

- ``interpolate`` (the default): at each sample x_d' sets off in a straight line from where it is to the new sample
  and arrives one interval T later. It adds one interval of latency and never leaves the segment between two
  commanded positions, so it cannot overshoot what the master sent.
- ``extrapolate``: x_d' is the newest sample moved on along the last two samples' slope for at most one interval
  (no latency; a turn of the hand is carried on for up to T before the next sample corrects it, and the correction
  is blended out over T).

Both feed forward the same acceleration for the whole interval: the change of the samples' slope (from their
stamps, so arrival jitter does not enter it) over the interval, (v_k - v_{k-1}) / T, low-pass filtered, and carried
on along its own last change (a first-order hold of the acceleration, which takes out the half interval by which a
flat hold would lag the path: near the arm's resonance a lagging feedforward acts as negative damping).

Either way a late or lost sample never runs away: the hold stops at the newest sample (interpolate) or one interval
beyond it along a bounded velocity (extrapolate), its velocity and acceleration go to zero there, and after
``master_timeout`` the replica's staleness watchdog (fic_core.desired_pose) holds x_d' still. Samples further apart
than ``GAP_INTERVALS`` learned intervals (a blackout, a restart) restart the estimates from rest; ``RELEARN_GAPS``
such intervals in a row that agree with each other are a new rate, not gaps, and the interval is learned again from
them (a link that slowed down, or an interval first learned from a burst: the master's first commands came 0.7-1.0 ms
apart in 2 of 18 main jobs, every later 10 ms interval then read as a gap, and the offset feedforward stayed off for
the whole run, error max 65-67 mm against 31-45). A segment never
moves faster than ``max_speed`` (a catch-up after a gap takes as long as that needs), and the estimates are clipped
to ``max_speed`` and ``max_acceleration``, as a difference quotient over a jittery interval is where a huge value
would come from.
"""
from __future__ import annotations

import math
from collections import deque

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_array, finite_scalar
from .norm_bound import norm_bounded

HOLD_DESIGNS = ("interpolate", "extrapolate")
#: Stamp intervals the learned sample interval is the median of.
INTERVAL_WINDOW = 9
#: Samples more than this many learned intervals apart are a gap: the estimates restart from rest.
GAP_INTERVALS = 2.5
#: The learned interval is kept within these bounds [s]: a 1 kHz link at the fast end, below 5 Hz (with jitter) at
#: the slow one; a longer interval is a gap, not a rate.
MIN_INTERVAL_S = 0.001
MAX_INTERVAL_S = 0.3
#: Gap intervals in a row, each within this factor of the others and at most MAX_INTERVAL_S, that are a new rate.
RELEARN_GAPS = 3
RELEARN_SPREAD = 1.5


class SampleInterval:
    """The link's sample interval T, learned from the stamps: the median of the last INTERVAL_WINDOW intervals."""

    def __init__(self) -> None:
        self._intervals: deque[float] = deque(maxlen=INTERVAL_WINDOW)
        self._value: float | None = None
        self._gaps: deque[float] = deque(maxlen=RELEARN_GAPS)   # the gap intervals since the last regular one

    @property
    def value(self) -> float | None:
        """T [s], None until two samples have come in."""
        return self._value

    def is_gap(self, elapsed: float) -> bool:
        """Whether two samples ``elapsed`` apart are a gap in the stream rather than one interval of it."""
        limit = MAX_INTERVAL_S if self._value is None else min(GAP_INTERVALS * self._value, MAX_INTERVAL_S)
        return elapsed > limit or elapsed < 0.0

    def add(self, elapsed: float) -> None:
        """One interval between successive samples' stamps (a gap's is passed to ``relearns`` instead)."""
        self._gaps.clear()
        self._intervals.append(min(max(elapsed, MIN_INTERVAL_S), MAX_INTERVAL_S))
        self._value = float(np.median(self._intervals))

    def relearns(self, elapsed: float) -> bool:
        """A gap interval: whether it completes RELEARN_GAPS in a row that agree (a new rate, module docstring); if
        so the interval is learned again from them alone and the caller takes this one as regular."""
        if not 0.0 < elapsed <= MAX_INTERVAL_S:
            self._gaps.clear()   # a blackout or a stamp out of order: no rate
            return False
        self._gaps.append(elapsed)
        if len(self._gaps) < RELEARN_GAPS or max(self._gaps) > RELEARN_SPREAD * min(self._gaps):
            return False
        gaps = list(self._gaps)
        self.reset()
        for interval in gaps[:-1]:   # the last one the caller adds, as any regular interval
            self.add(interval)
        return True

    def reset(self) -> None:
        self._intervals.clear()
        self._value = None
        self._gaps.clear()


class LinkHold:
    """x_d' between link samples, with its velocity and its acceleration for the feedforward (module docstring)."""

    def __init__(self, design: str = "interpolate", *, dimension: int = 3, acceleration_time_constant: float = 0.05,
                 min_sample_interval: float = 0.0005, max_speed: float = 1.0,
                 max_acceleration: float = 10.0) -> None:
        """
        Args:
            design: "interpolate" or "extrapolate" (module docstring).
            dimension: size of the set-point (3 for a TCP position).
            acceleration_time_constant: low-pass time constant of the acceleration estimate [s] (>= 0; 0: raw).
            min_sample_interval: a sample closer than this to the last [s] (a burst, a duplicate) moves the hold's
                goal but changes neither the estimates nor the learned interval.
            max_speed: the hold never moves faster than this [m/s] (> 0).
            max_acceleration: the acceleration estimate's norm is clipped to this [m/s^2] (> 0).
        """
        if design not in HOLD_DESIGNS:
            raise FicInputError(f"link hold design must be one of {HOLD_DESIGNS}, got {design!r}")
        if isinstance(dimension, bool) or not isinstance(dimension, (int, np.integer)) or dimension < 1:
            raise FicInputError(f"dimension must be a positive integer, got {dimension!r}")
        self.design = design
        self.dimension = int(dimension)
        self.acceleration_time_constant = finite_scalar("acceleration_time_constant", acceleration_time_constant,
                                                        minimum=0.0)
        self.min_sample_interval = finite_scalar("min_sample_interval", min_sample_interval, minimum=0.0)
        self.max_speed = finite_scalar("max_speed", max_speed, minimum=0.0, minimum_inclusive=False)
        self.max_acceleration = finite_scalar("max_acceleration", max_acceleration, minimum=0.0,
                                              minimum_inclusive=False)
        self.interval = SampleInterval()
        self.reset()

    def reset(self) -> None:
        """Forget every sample and the learned interval."""
        self.interval.reset()
        self._stamp: float | None = None              # the newest sample's stamp (sender's clock) [s]
        self._sample = np.zeros(self.dimension)         # the newest sample
        self._origin = np.zeros(self.dimension)         # where the current segment starts
        self._start = 0.0                               # when it starts (our clock) [s]
        self._duration = 0.0                            # how long it moves [s]
        self._velocity = np.zeros(self.dimension)       # its velocity [m/s]
        self._acceleration = np.zeros(self.dimension)   # the filtered acceleration at the segment's start [m/s^2]
        self._jerk = np.zeros(self.dimension)           # its change over the segment [m/s^3]
        self._sample_slope = np.zeros(self.dimension)   # the last two samples' slope (extrapolate) [m/s]
        self._estimates_valid = False                   # whether _velocity is a rate of the stream, not a catch-up

    @property
    def has_sample(self) -> bool:
        return self._stamp is not None

    def add(self, stamp: float, position: ArrayLike, received: float) -> None:
        """A new sample: ``position`` as of its ``stamp`` (the sender's clock), taken in at ``received`` (ours).

        Raises FicInputError on NaN/Inf (nothing changes then)."""
        stamp = finite_scalar("stamp", stamp)
        received = finite_scalar("received", received)
        position = finite_array("position", position, (self.dimension,)).copy()
        if self._stamp is None:
            self._stamp = stamp
            self._sample = position
            self._origin = position
            self._start, self._duration = received, 0.0
            return
        elapsed = stamp - self._stamp
        here = self.position(received)
        gap = self.interval.is_gap(elapsed) and not self.interval.relearns(elapsed)
        burst = not gap and elapsed < self.min_sample_interval
        if not gap and not burst:
            self.interval.add(elapsed)
        interval = self.interval.value or max(elapsed, self.min_sample_interval)
        previous_slope = self._sample_slope
        if gap:
            self._sample_slope = np.zeros(self.dimension)
        elif not burst:
            with np.errstate(over="ignore", invalid="ignore"):
                slope = (position - self._sample) / elapsed
            self._sample_slope = norm_bounded(slope, self.max_speed) if np.isfinite(slope).all() \
                else np.zeros(self.dimension)
        self._stamp = stamp if not burst else self._stamp
        self._sample = position
        # The new segment: from where the hold is to where it is going, at most max_speed.
        goal = position if self.design == "interpolate" else position + self._sample_slope * interval
        with np.errstate(over="ignore", invalid="ignore"):
            distance = goal - here
        if not np.isfinite(distance).all():   # a jump too large for a float difference: a step, at rest
            self._origin, self._start, self._duration = position, received, 0.0
            self._velocity = np.zeros(self.dimension)
            self._acceleration = np.zeros(self.dimension)
            self._jerk = np.zeros(self.dimension)
            self._estimates_valid = False
            return
        length = math.sqrt(float(distance.dot(distance)))
        duration = max(interval, length / self.max_speed)
        self._origin, self._start, self._duration = here, received, duration
        self._velocity = distance / duration
        if gap:
            # After a gap the segment is a catch-up, not the operator's motion: nothing to feed forward; the
            # second regular sample after it starts the estimates again.
            self._acceleration = np.zeros(self.dimension)
            self._jerk = np.zeros(self.dimension)
            self._estimates_valid = False
            return
        if burst:   # a burst's slope says nothing reliable: the estimates stay as they were
            return
        if not self._estimates_valid:   # the first regular segment: its slope is the first rate of the stream
            self._acceleration = np.zeros(self.dimension)
            self._jerk = np.zeros(self.dimension)
            self._estimates_valid = True
            return
        # The velocity's change at this sample, from the samples' stamps (arrival jitter does not enter it), spread
        # over the interval that follows and low-pass filtered (backward Euler of a first-order lag).
        change = self._sample_slope - previous_slope
        # The finite difference over one interval already averages over T: the low-pass adds the rest of
        # acceleration_time_constant (at 10 Hz nothing, at 100 Hz most of it, where second differences of 10 ms
        # samples are noisy).
        filter_time_constant = max(self.acceleration_time_constant - interval, 0.0)
        blend = interval / (filter_time_constant + interval)
        previous_acceleration = self._acceleration
        self._acceleration = norm_bounded(self._acceleration + (change / interval - self._acceleration) * blend,
                                          self.max_acceleration)
        # The estimate describes the velocity's change at this sample, half an interval (and the filter) behind the
        # path the arm is sent along; held flat over the interval, a feedforward that late pushes along the
        # velocity near the arm's resonance (a lag d adds m d w^2 v: negative damping). It is carried on along its
        # own last change instead (a first-order hold of the acceleration), bounded as the estimate is.
        self._jerk = (self._acceleration - previous_acceleration) / interval

    def moving(self, now: float) -> bool:
        """Whether the hold is moving along a segment at ``now`` (it stops at the segment's end until a sample)."""
        return self._stamp is not None and now - self._start < self._duration

    def position(self, now: float) -> NDArray[np.float64]:
        """x_d' at ``now`` (our clock): along the current segment, stopped at its end."""
        if self._stamp is None:
            raise FicInputError("no sample yet")
        if self._duration <= 0.0:
            return self._origin.copy()
        travelled = min(max(now - self._start, 0.0), self._duration)
        # origin + v t per axis on Python floats: numpy's per-call cost is most of this on 3-vectors, twice a tick.
        return np.array([origin + velocity * travelled
                         for origin, velocity in zip(self._origin.tolist(), self._velocity.tolist())])

    def velocity(self, now: float) -> NDArray[np.float64]:
        """The hold's velocity at ``now``: the segment's, zero once it stopped."""
        return self._velocity.copy() if self.moving(now) else np.zeros(self.dimension)

    def acceleration(self, now: float) -> NDArray[np.float64]:
        """The acceleration fed forward at ``now``: the filtered estimate while the hold moves, zero once stopped."""
        if not self.moving(now):
            return np.zeros(self.dimension)
        return norm_bounded(self._acceleration + self._jerk * min(now - self._start, self._duration),
                            self.max_acceleration)
