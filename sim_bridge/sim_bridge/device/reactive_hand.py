"""A force-reactive operator's hand: the passive spring-damper plus a stretch reflex and a voluntary response.

``virtual_operator.Hand`` is the optimistic operator: a relaxed arm (300 N/m, 15 N s/m) whose lean-in toward its
target sees the handle at once. A person holding a haptic handle answers what it feels in three epochs after a
perturbation (Pruszynski and Scott 2012, "Optimal feedback control and the long-latency stretch response",
Exp Brain Res 218:341-359): the muscles' intrinsic impedance at once, a short-latency stretch reflex 20-50 ms after
the stretch, then (after the long-latency reflex at 50-100 ms) a voluntary response beyond 100 ms. Measured simple
reaction times to a tactile or visual onset are 0.15-0.25 s (Kosinski 2008, "A literature review on reaction
time", Clemson University). This hand models each:

    f = K_c (p* - x) - B_c v                                  intrinsic (instantaneous), p* = target + correction
        - K_r d(t - T_r) - B_r v(t - T_r)                     stretch reflex, d = x - p*   (T_r = 30-50 ms)
    dcorrection/dt = k_v (target - x)(t - T_v)                voluntary: hold the intended position (T_v = 0.15-0.25 s)
    K_c = K (1 + c min(|F_felt(t - T_v)|, F_sat)),  B_c = B (1 + c min(...))   co-contraction against the felt force

- The reflex is a delayed stiffness and viscosity on the stretch of the arm away from where the operator holds it:
  muscle spindles sense length and (mostly) lengthening speed, and the short-latency reflex returns them to the
  same muscle after the spinal loop's 20-50 ms.
- The voluntary response acts on what was felt a reaction time ago: the operator pushes the handle back toward the
  intended position (the lean-in of ``Hand`` made to wait for the reaction time), and stiffens the arm by
  co-contraction as the felt force grows. Stiffness rises with the force the arm resists (Lacquaniti, Licata and
  Soechting 1982, "The mechanical behavior of the human forearm in response to transient perturbations", Biol
  Cybern 44:35-46: stiffness and viscosity rise when told to resist; Tee, Burdet, Chew and Milner 2004, "A model of
  force and impedance in human arm movements", Biol Cybern 90:368-375: stiffness linear in the joint torque's
  magnitude). The co-contraction is capped at three times the relaxed impedance: the upper end of the hand
  stiffness measured during maintained posture (a few hundred to about 1000 N/m; Mussa-Ivaldi, Hogan and Bizzi
  1985, "Neural, mechanical, and geometric factors subserving arm posture in humans", J Neurosci 5:2732-2743).

The latencies are the literature's; the gains are this model's choice (no study gives them for a hand on a
sigma.7-class handle): the reflex at a third of the intrinsic stiffness, the voluntary correction at 2-4 1/s (its
delayed integrator keeps k_v T_v below pi/2, so the hand alone on the handle settles), the co-contraction at
2-8 % of the relaxed impedance per newton felt. ``ReactiveHandParameters.drawn`` draws each from its documented
range for a seed; test/sim/test_reactive_hand.py checks that the hand alone on the device settles at the extremes.
"""
from __future__ import annotations

import math
from bisect import bisect_right
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.errors import finite_array, finite_scalar
from fic_core.norm_bound import norm_bounded
from sim_bridge.device.virtual_operator import Hand, HandParameters

Vector3 = NDArray[np.float64]

#: The ranges a seed draws from (uniform), module docstring: (low, high).
REFLEX_LATENCY_RANGE_S = (0.030, 0.050)
REFLEX_STIFFNESS_FRACTION_RANGE = (0.25, 0.40)      # of the intrinsic stiffness K
REFLEX_DAMPING_FRACTION_RANGE = (0.15, 0.30)        # of the intrinsic damping B
VOLUNTARY_REACTION_TIME_RANGE_S = (0.15, 0.25)
VOLUNTARY_RATE_RANGE = (2.0, 4.0)                   # k_v [1/s]
COCONTRACTION_PER_NEWTON_RANGE = (0.02, 0.08)       # c [1/N]


@dataclass(frozen=True)
class ReactiveHandParameters:
    reflex_latency: float = 0.04            # T_r [s]
    reflex_stiffness: float = 100.0         # K_r [N/m]
    reflex_damping: float = 3.0             # B_r [N s/m]
    voluntary_reaction_time: float = 0.2    # T_v [s]
    voluntary_rate: float = 3.0             # k_v [1/s]
    cocontraction_per_newton: float = 0.05  # c [1/N]
    max_cocontraction: float = 2.0          # c * |F| is capped here: at most 3x the relaxed impedance

    def __post_init__(self) -> None:
        for name in ("reflex_latency", "reflex_stiffness", "reflex_damping", "voluntary_reaction_time",
                     "voluntary_rate", "cocontraction_per_newton", "max_cocontraction"):
            finite_scalar(name, getattr(self, name), minimum=0.0)

    @classmethod
    def drawn(cls, draws: np.random.Generator, hand: HandParameters) -> "ReactiveHandParameters":
        """One operator's figures, each uniform in its range (module constants), the reflex's gains as fractions of
        ``hand``'s intrinsic stiffness and damping."""
        return cls(reflex_latency=float(draws.uniform(*REFLEX_LATENCY_RANGE_S)),
                   reflex_stiffness=float(draws.uniform(*REFLEX_STIFFNESS_FRACTION_RANGE)) * hand.stiffness,
                   reflex_damping=float(draws.uniform(*REFLEX_DAMPING_FRACTION_RANGE)) * hand.damping,
                   voluntary_reaction_time=float(draws.uniform(*VOLUNTARY_REACTION_TIME_RANGE_S)),
                   voluntary_rate=float(draws.uniform(*VOLUNTARY_RATE_RANGE)),
                   cocontraction_per_newton=float(draws.uniform(*COCONTRACTION_PER_NEWTON_RANGE)))


class ReactiveHand(Hand):
    """The hand of the module docstring. ``update`` is called at the device node's rate with the handle's state and
    the force the handle renders (the felt force); ``force`` at every device substep, as for ``Hand``."""

    def __init__(self, parameters: HandParameters | None = None,
                 reactive: ReactiveHandParameters | None = None) -> None:
        super().__init__(parameters)
        self.reactive = reactive if reactive is not None else ReactiveHandParameters()
        self._time = 0.0
        # (time, stretch d, handle velocity, |felt force|, target - x) at each update, oldest first.
        self._history: deque[tuple[float, Vector3, Vector3, float, Vector3]] = deque()
        self._history_times: deque[float] = deque()
        self._reflex = np.zeros(3)
        self._cocontraction = 0.0

    @property
    def cocontraction(self) -> float:
        """The present impedance scale minus one (0: relaxed)."""
        return self._cocontraction

    @property
    def reflex_force(self) -> Vector3:
        return self._reflex.copy()

    def _delayed(self, latency: float) -> tuple[float, Vector3, Vector3, float, Vector3] | None:
        """The newest sample at least ``latency`` old (None before one is)."""
        index = bisect_right(self._history_times, self._time - latency + 1e-12) - 1
        return self._history[index] if index >= 0 else None

    def update(self, target: ArrayLike, handle_position: ArrayLike, dt: float,
               handle_velocity: ArrayLike | None = None, felt_force: ArrayLike | None = None) -> None:
        """Advance the hand's clock by ``dt``, record what it senses now, and set the reflex force, the
        co-contraction and the voluntary correction from what it sensed one latency ago."""
        self.target = finite_array("target", target, shape=(3,)).copy()
        position = finite_array("handle_position", handle_position, shape=(3,))
        velocity = np.zeros(3) if handle_velocity is None else finite_array("handle_velocity", handle_velocity,
                                                                            shape=(3,))
        if felt_force is None:
            felt = 0.0
        else:   # |F|: math.sqrt(F.F), the value np.linalg.norm gives a float vector, without its dispatch
            felt_vector = finite_array("felt_force", felt_force, shape=(3,))
            felt = math.sqrt(float(felt_vector.dot(felt_vector)))
        dt = finite_scalar("dt", dt, minimum=0.0)
        self._time += dt
        r = self.reactive
        stretch = position - (self.target + self.correction)
        self._history.append((self._time, stretch, velocity.copy(), felt, self.target - position))
        self._history_times.append(self._time)
        horizon = max(r.reflex_latency, r.voluntary_reaction_time) + 0.1
        while len(self._history) > 2 and self._history_times[1] <= self._time - horizon:
            self._history.popleft()
            self._history_times.popleft()
        reflex = self._delayed(r.reflex_latency)
        self._reflex = np.zeros(3) if reflex is None else -(r.reflex_stiffness * reflex[1]
                                                             + r.reflex_damping * reflex[2])
        voluntary = self._delayed(r.voluntary_reaction_time)
        if voluntary is not None:
            self._cocontraction = min(r.cocontraction_per_newton * voluntary[3], r.max_cocontraction)
            if self.parameters.correction_rate > 0.0:
                self.correction = norm_bounded(self.correction + r.voluntary_rate * dt * voluntary[4],
                                               self.parameters.max_correction)

    def force(self, position: Vector3, velocity: Vector3) -> Vector3:
        parameters = self.parameters
        scale = 1.0 + self._cocontraction
        stiffness, damping = scale * parameters.stiffness, scale * parameters.damping
        # Per axis on Python floats, the operations and their order of the array form (Hand.force).
        force = np.array([stiffness * (aim + shift - at) - damping * speed + reflex
                          for aim, shift, at, speed, reflex in zip(self.target.tolist(), self.correction.tolist(),
                                                                   position.tolist(), velocity.tolist(),
                                                                   self._reflex.tolist())])
        return norm_bounded(force, parameters.max_force)

