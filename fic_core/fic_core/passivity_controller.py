"""The passivity controllers of a delayed channel's two sides: the variable damper of time-domain passivity.

Each side of the channel watches its observer W (fic_core.channel_passivity_observer). When a tick would let out
more energy than the other side put in (W would go below zero), the controller at that side dissipates the
difference in the same tick (Ryu and Hannaford, "Time domain passivity control of haptic interfaces", IEEE T-RA
18(1), 2002; the delayed-channel form of Ryu, Artigas and Preusche). Which variable it can change depends on what
the channel gives out at that port:

- a FORCE (the master side: the replica's force F_R, rendered on the handle). Power into the channel
  P = -F . v (the handle's port velocity v moving against F puts energy in). The controller is a series damper:
  F' = F - alpha v, alpha = -W / (dt |v|^2), so that P' = P + alpha |v|^2 lets out exactly what W allows.
- a MOTION (the replica side: the offset x_d' the replica tracks). Power into the channel P = F . v, with v the
  delivered offset's rate and F the force the replica sends back. The controller is a parallel one: the delivered
  rate becomes v' = v + beta F, beta = -W / (dt |F|^2), and the offset it delivers is the sum of those rates (so
  it drifts from the received one by what was dissipated; the drift is reported, not corrected).

Both act only on a tick that lets energy out (P < 0) and never dissipate more than that tick lets out, so a
positive W leaves the signal untouched (damping zero). With ``enabled`` False a controller only books its observer (the
signal passes unchanged). A bound on the damping (the damper) or on the offset correction per tick (the motion side)
keeps a near-zero v or F from asking for an unbounded gain; a tick that hits it leaves the rest of the deficit in W, for
the next ticks to take out.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.channel_passivity_observer import ChannelPortObserver
from fic_core.errors import finite_array, finite_scalar

#: Below this |v|^2 or |F|^2 nothing flows through the port that a damper could take out.
NEGLIGIBLE_SQUARE = 1e-18


def _dissipation(observer: ChannelPortObserver, power: float, dt: float) -> float:
    """The power [W] the controller must take out of this tick: what would bring W below zero, at most the
    tick's own output (module docstring)."""
    if power >= 0.0 or dt <= 0.0:
        return 0.0
    deficit = -observer.tentative(power, dt)
    return min(deficit, -power * dt) / dt if deficit > 0.0 else 0.0


class ForcePortPassivityController:
    """The variable damper at the side where the channel gives out a force (module docstring)."""

    def __init__(self, max_damping: float = math.inf, enabled: bool = True) -> None:
        #: False: the observer books the port and the force passes unchanged (the channel's energy, watched only).
        self.enabled = bool(enabled)
        self.max_damping = finite_scalar("max_damping", max_damping, minimum=0.0) if math.isfinite(max_damping) \
            else math.inf
        self.observer = ChannelPortObserver()
        self.damping = 0.0     # alpha of the last tick [N s/m]

    def reset(self) -> None:
        self.observer.reset()
        self.damping = 0.0

    def step(self, force: ArrayLike, velocity: ArrayLike, dt: float) -> NDArray[np.float64]:
        """The force to render, F - alpha v, for the channel's ``force`` [N] and the port ``velocity`` [m/s] over
        ``dt`` [s]; the tick is booked in the observer."""
        force = finite_array("force", force)
        velocity = finite_array("velocity", velocity, force.shape)
        dt = finite_scalar("dt", dt, minimum=0.0)
        power = -float(force @ velocity)
        square = float(velocity @ velocity)
        needed = _dissipation(self.observer, power, dt) if self.enabled else 0.0
        self.damping = min(needed / square, self.max_damping) if needed > 0.0 and square > NEGLIGIBLE_SQUARE else 0.0
        damped = force - self.damping * velocity
        self.observer.observe(-float(damped @ velocity), dt)
        return damped


class MotionPortPassivityController:
    """The correction at the side where the channel gives out a motion (module docstring)."""

    def __init__(self, max_correction: float, enabled: bool = True) -> None:
        #: False: the observer books the port and the offset passes unchanged (the channel's energy, watched only).
        self.enabled = bool(enabled)
        #: Bound on |beta F dt|, the offset correction of one tick [m].
        self.max_correction = finite_scalar("max_correction", max_correction, minimum=0.0)
        self.observer = ChannelPortObserver()
        self.reset()

    def reset(self) -> None:
        self.observer.reset()
        self._received: NDArray[np.float64] | None = None
        self._delivered: NDArray[np.float64] | None = None
        self.gain = 0.0        # beta of the last tick [m/(N s)]

    @property
    def drift(self) -> NDArray[np.float64]:
        """Delivered minus received offset [m]: what the controller's corrections add up to."""
        if self._received is None or self._delivered is None:
            return np.zeros(0)
        return self._delivered - self._received

    def step(self, received: ArrayLike, force: ArrayLike, dt: float) -> NDArray[np.float64]:
        """The offset to deliver for the ``received`` one [m], with ``force`` [N] the force this side sends back
        and ``dt`` [s] since the last call; the tick is booked in the observer. The first call delivers
        ``received`` as it is."""
        received = finite_array("received", received).copy()
        force = finite_array("force", force, received.shape)
        dt = finite_scalar("dt", dt, minimum=0.0)
        if self._received is None or self._delivered is None:
            self._received, self._delivered = received, received.copy()
        if dt == 0.0:   # the first call, or a repeat at the same instant: no rate to book
            self.gain = 0.0
            if not self.enabled:
                self._received, self._delivered = received, received.copy()
            return self._delivered.copy()
        velocity = (received - self._received) / dt
        power = float(force @ velocity)
        square = float(force @ force)
        needed = _dissipation(self.observer, power, dt) if self.enabled else 0.0
        gain = needed / square if needed > 0.0 and square > NEGLIGIBLE_SQUARE else 0.0
        correction = gain * dt * math.sqrt(square)
        if correction > self.max_correction:
            gain *= self.max_correction / correction
        self.gain = gain
        delivered_velocity = velocity + gain * force
        self.observer.observe(float(force @ delivered_velocity), dt)
        self._received = received
        # Disabled, it delivers the received offset exactly (no sum of rates rounding away from it).
        self._delivered = self._delivered + delivered_velocity * dt if self.enabled else received.copy()
        return self._delivered.copy()
