"""Set-points that arrive as samples slower than the control loop: x_d' through the channel, x_d'' from the planner.

The replica's law runs at 0.5-1 kHz; x_d' arrives at the master's network rate (100 Hz) after the channel's delay
and x_d'' at the planner's publish rate (100 Hz). Held as steps, x_d jumps every 10 ms, its difference quotient
is a train of spikes, and nothing tells the law how the set-point accelerates, so the FIC can only track it
through its error (with K0 = 200 N/m, every N of inertia or friction not fed forward is 5 mm of error).

``SampledSetPoint`` is a first-order hold: between samples the set-point moves on along the velocity of the last
two samples (taken from their stamps, so that network jitter in the arrival does not enter the slope), for at
most ``max_extrapolation`` seconds (a late or lost sample then holds the set-point still, it never runs away).
The acceleration estimate, the difference of successive velocities low-pass filtered over
``acceleration_time_constant``, is what the replica feeds forward through J^T Lambda (replica.py). Samples
further apart than ``max_sample_gap`` (a blackout, a restart; and a stamp that far behind the last one, so that a
single stamp far in the future cannot make every later sample look older) restart the estimates from rest there,
and a jump too large for a float difference (1e308 against -1e308) is a step, never an Inf or a NaN. Bad timing must
not become motion: a sample closer than ``min_sample_interval`` to the last one (a burst after a stalled sender,
a duplicate) moves the hold but does not change the slope, and the estimates are clipped to ``max_speed`` and
``max_acceleration`` (a difference quotient over a short, jittery interval is where a huge velocity would come
from; the extrapolation would turn it into a jump of x_d). When a sample lands away from where the hold had got
to (after a gap in the stream: a stalled sender, a lost message), the difference is blended out over
``blend_time`` instead of stepping, so x_d stays continuous.

``ShrinkingOffset`` takes a jump out of a set-point without stopping it: when the set-point in use and the
commanded one disagree (the planner's first pose is far from where the arm starts; x_d' comes back after a
blackout), the difference is kept as an offset that shrinks toward zero at a bounded speed while the commanded
set-point goes on moving underneath. An approach that chases the commanded point at a bounded speed never
arrives when the point moves faster than that speed (the paper's circle moves at 0.126 m/s, faster than the
0.1 m/s resume speed): the offset's shrinking does not depend on how the set-point moves.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_array, finite_scalar
from .norm_bound import norm_bounded


class SampledSetPoint:
    """First-order hold of a sampled set-point, with its velocity and a filtered acceleration (module docstring)."""

    def __init__(self, dimension: int = 3, *, acceleration_time_constant: float = 0.05,
                 max_extrapolation: float = 0.05, max_sample_gap: float = 0.1, min_sample_interval: float = 0.002,
                 max_speed: float = 1.0, max_acceleration: float = 10.0, blend_time: float = 0.05) -> None:
        """
        Args:
            dimension: size of the set-point (3 for a TCP position).
            acceleration_time_constant: low-pass time constant of the acceleration estimate [s] (>= 0; 0: raw).
            max_extrapolation: the hold moves on along the velocity for at most this long after a sample [s].
            max_sample_gap: samples further apart than this [s] restart the velocity and acceleration from zero.
            min_sample_interval: a sample closer than this to the last [s] does not change the estimates.
            max_speed: the velocity estimate's norm is clipped to this [m/s] (> 0).
            max_acceleration: the acceleration estimate's norm is clipped to this [m/s^2] (> 0).
            blend_time: a new sample's distance from the hold's output is blended out over this long [s] (0: steps).
        """
        if isinstance(dimension, bool) or not isinstance(dimension, (int, np.integer)) or dimension < 1:
            raise FicInputError(f"dimension must be a positive integer, got {dimension!r}")
        self.dimension = int(dimension)
        self.acceleration_time_constant = finite_scalar("acceleration_time_constant", acceleration_time_constant,
                                                        minimum=0.0)
        self.max_extrapolation = finite_scalar("max_extrapolation", max_extrapolation, minimum=0.0)
        self.max_sample_gap = finite_scalar("max_sample_gap", max_sample_gap, minimum=0.0, minimum_inclusive=False)
        self.min_sample_interval = finite_scalar("min_sample_interval", min_sample_interval, minimum=0.0)
        self.max_speed = finite_scalar("max_speed", max_speed, minimum=0.0, minimum_inclusive=False)
        self.max_acceleration = finite_scalar("max_acceleration", max_acceleration, minimum=0.0,
                                              minimum_inclusive=False)
        self.blend_time = finite_scalar("blend_time", blend_time, minimum=0.0)
        self.reset()

    def reset(self) -> None:
        """Forget every sample."""
        self._stamp: float | None = None   # stamp of the sample the slope is measured from
        self._slope_position = np.zeros(self.dimension)
        self._received = 0.0
        self._jump = np.zeros(self.dimension)  # hold output - new sample, at the sample's arrival
        self._position = np.zeros(self.dimension)
        self._velocity = np.zeros(self.dimension)
        self._acceleration = np.zeros(self.dimension)

    @property
    def has_sample(self) -> bool:
        return self._stamp is not None

    def add(self, stamp: float, position: ArrayLike, received: float) -> None:
        """A new sample: ``position`` as of its ``stamp`` (the sender's clock), taken in at ``received`` (ours).

        A stamp less than min_sample_interval newer than the last one's (repeated, reordered, a burst) replaces
        the position only: it says nothing reliable about the slope. Raises FicInputError on NaN/Inf.
        """
        stamp = finite_scalar("stamp", stamp)
        received = finite_scalar("received", received)
        position = finite_array("position", position, (self.dimension,)).copy()
        # Where the hold had got to: the new sample's distance from it is blended out, not stepped (unless the
        # distance is not even a float: a finite but huge sample, 1e308 against -1e308, is taken as a step).
        jump = np.zeros(self.dimension)
        if self._stamp is not None and self.blend_time > 0.0:
            with np.errstate(over="ignore", invalid="ignore"):
                jump = self.position(received) - position
            if not np.isfinite(jump).all():
                jump = np.zeros(self.dimension)
        self._jump = jump
        elapsed = None if self._stamp is None else stamp - self._stamp
        if elapsed is not None and abs(elapsed) > self.max_sample_gap:
            # A blackout, a restart, or a stamp far off ours (far ahead or far behind the last one): the
            # estimates restart from rest at this sample. (Kept as the slope's reference, so that one stamp far in
            # the future cannot make every later sample "older" and freeze the estimates for good.)
            self._velocity[:] = 0.0
            self._acceleration[:] = 0.0
        elif elapsed is not None and elapsed >= self.min_sample_interval:
            with np.errstate(over="ignore", invalid="ignore"):
                velocity = (position - self._slope_position) / elapsed
            if np.isfinite(velocity).all():
                velocity = norm_bounded(velocity, self.max_speed)
                # Low-pass of the velocity's difference quotient (backward Euler of a first-order lag).
                blend = elapsed / (self.acceleration_time_constant + elapsed)
                self._acceleration = norm_bounded(
                    self._acceleration + ((velocity - self._velocity) / elapsed - self._acceleration) * blend,
                    self.max_acceleration)
                self._velocity = velocity
            else:  # a jump too large for a float difference says nothing about a slope: restart from rest
                self._velocity[:] = 0.0
                self._acceleration[:] = 0.0
        if elapsed is None or elapsed >= self.min_sample_interval or abs(elapsed) > self.max_sample_gap:
            self._stamp = stamp
            self._slope_position = position
        self._position = position
        self._received = received

    def _extrapolation(self, now: float) -> float:
        return min(max(now - self._received, 0.0), self.max_extrapolation)

    def position(self, now: float) -> NDArray[np.float64]:
        """The set-point at ``now`` (our clock): the last sample moved on along the velocity for the time since
        it came in, at most max_extrapolation."""
        if self._stamp is None:
            raise FicInputError("no sample yet")
        extrapolation = self._extrapolation(now)
        # x + v t (+ jump w) per axis on Python floats: the array form's operations in its order (the same
        # numbers), without numpy's per-call cost on 3-vectors; this runs twice a control tick.
        moved = [position + velocity * extrapolation
                 for position, velocity in zip(self._position.tolist(), self._velocity.tolist())]
        if self.blend_time > 0.0:
            remaining = 1.0 - (now - self._received) / self.blend_time
            if remaining > 0.0:
                weight = min(remaining, 1.0)
                moved = [position + jump * weight for position, jump in zip(moved, self._jump.tolist())]
        return np.array(moved)

    def velocity(self, now: float) -> NDArray[np.float64]:
        """The hold's velocity at ``now``: that of the last two samples, zero once the hold stops moving."""
        if self._stamp is None or now - self._received > self.max_extrapolation:
            return np.zeros(self.dimension)
        return self._velocity.copy()

    def acceleration(self, now: float) -> NDArray[np.float64]:
        """The filtered acceleration estimate, zero once the hold stops moving."""
        if self._stamp is None or now - self._received > self.max_extrapolation:
            return np.zeros(self.dimension)
        return self._acceleration.copy()


class ShrinkingOffset:
    """A jump taken out of a set-point, given back at a bounded speed (module docstring)."""

    def __init__(self, dimension: int = 3) -> None:
        self._offset = np.zeros(int(dimension))
        self._speed = 0.0
        # Whether the offset has a non-zero element, kept with every change of it: asked twice or more a control
        # tick, where the offset is zero nearly always (numpy's any() costs more than the rest of an idle apply).
        self._active = False

    @property
    def active(self) -> bool:
        """Whether some of the jump is still being given back."""
        return self._active

    @property
    def offset(self) -> NDArray[np.float64]:
        return self._offset.copy()

    def start(self, in_use: ArrayLike, commanded: ArrayLike, speed: float) -> None:
        """The set-point in use is ``in_use`` and should become ``commanded``: keep the difference, to be given
        back at ``speed`` [m/s] (> 0)."""
        self._speed = finite_scalar("speed", speed, minimum=0.0, minimum_inclusive=False)
        self._offset = finite_array("in_use", in_use, self._offset.shape) - \
            finite_array("commanded", commanded, self._offset.shape)
        self._active = bool(self._offset.any())

    def stop(self) -> None:
        self._offset[:] = 0.0
        self._active = False

    def apply(self, commanded: ArrayLike, dt: float) -> NDArray[np.float64]:
        """The set-point to use for ``commanded`` after ``dt`` more seconds: commanded + the offset left."""
        if self._active:
            norm = math.sqrt(float(self._offset.dot(self._offset)))
            step = self._speed * dt
            if norm <= step:
                self._offset[:] = 0.0
            else:
                self._offset *= 1.0 - step / norm
            self._active = bool(self._offset.any())   # a factor can round the last of it to zero
        return finite_array("commanded", commanded, self._offset.shape) + self._offset
