"""An observer of the energy a controller's port really exchanges: the effort held over each step times the
measured motion, against a storage the caller computes without the rule under test.

Why another observer: fic_core/passivity_observer.py books the attractor's own port sum against the attractor's own
storage, so it checks the switching rule's bookkeeping but cannot see what a sampled controller does to the plant:
the effort is held between samples (zero-order hold), the motion is what the sensors measure, the moment of a
rotation acts on the real rotation, and the effort that reaches the plant may differ from the law's (slew, QP).
This observer books, per tick k (Ryu and Hannaford's passivity observer, in its zero-order-hold form):

    W_k = W_{k-1} + u_{k-1} . (x_k - x_{k-1})          (the exchanged work: energy into the controller) [J]
    margin_k = W_k - (V_k - V_0)                        V: the storage the caller passes [J]
    S_k = S_{k-1} + (u_k - u_{k-1}) . (x_k - x_{k-1})   (the sampling term) [J]
    Q_k = Q_{k-1} + |x_k - x_{k-1}|^2 / dt              (integral of |velocity|^2 dt) [m^2/s or rad^2/s]

Sign convention: ``u . dx`` must be the energy flowing INTO the controller. For the FIC that is the force it applies
and its error coordinate, ``u = FIC(e)``, ``x = e = x_d - x_robot`` (the target's motion minus the measured motion of
the robot). For an effort u applied to a plant whose measured coordinate is q (a joint torque after the slew and
the QP, for instance), pass ``x = -q``. A rotation has no global coordinate: pass the running sum of its measured
base-frame increments, ``x_k = x_{k-1} + (log3(R_d,k R_d,k-1^T) - log3(R_k R_k-1^T))`` (target minus robot), so that
each difference is the increment itself.

What is judged. If the effort is the gradient of a storage V that is convex along each step (every FIC phase
is, for translation per axis and for the angle-axis rotation, fic_core/rotational_attractor.py), then the sum with
the effort after each step, ``W_k + S_k``, is at least ``V_k - V_0``: the held effort can fall short of the
storage by at most the sampling term S, which vanishes linearly with the period. A tick is a **violation** when
``margin_k + S_k < -tolerance_j``: energy came out that neither the storage nor the sampling accounts for (a
non-conservative field, a switch that raises the storage, an effort that is not the law's). The margin itself is
the **discrete-time shortfall** when negative: the energy the port gave out beyond its storage, held force
included, which the plant must dissipate; ``damping_needed`` is the smallest viscous damping that would have
covered it at every tick, ``max_k (-margin_k) / Q_k`` [N s/m, or N m s/rad].

The storage (the caller's choice, passed to ``observe``): it must not come from the rule being checked, or the
observer cannot fail. For the FIC, fic_core/attractor_storage.py's ``AttractorStorage`` computes the storage of
the attractor's declared phase state by its own quadrature of Eq. 1 (why not the plain V_D(|e|): that module's
docstring). For a PoseAttractor: ``AttractorStorage(translation profile)(snapshot.translation)`` plus
``AttractorStorage(rotation profile)(snapshot.rotation.scalar)`` (the angle's one-axis state).

Usage (one observer per port; H = the control period)::

    observer = ExchangedEnergyObserver(3, tolerance_j=1e-3, period_s=H)
    storage = AttractorStorage(profile)
    each tick:  force = attractor.force(error, rate)
                observer.observe(force, error, storage(attractor.snapshot()))
    observer.exchanged_work_j, .margin_j, .min_margin_j, .shortfall_j, .damping_needed, .violation_ticks
    observer.diagnostics()   # dict[str, str] for /diagnostics
    observer.reset()         # a new run (or a controller reset)
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from fic_core.errors import FicInputError, finite_floats, finite_scalar

#: Default tolerance beyond the sampling term [J]: above the rounding of a storage computed by quadrature
#: (~1e-9 J), below the energy of 1 mm against 1 N.
DEFAULT_TOLERANCE_J = 1e-3


class ExchangedEnergyObserver:
    """Held effort times measured displacement, against an independent storage (module docstring)."""

    def __init__(self, dof: int, tolerance_j: float = DEFAULT_TOLERANCE_J, period_s: float = 1e-3) -> None:
        if isinstance(dof, bool) or not isinstance(dof, (int, np.integer)) or dof < 1:
            raise FicInputError(f"dof must be a positive integer, got {dof!r}")
        self._dof = int(dof)
        self.tolerance_j = finite_scalar("tolerance_j", tolerance_j, minimum=0.0)
        self.period_s = finite_scalar("period_s", period_s, minimum=0.0, minimum_inclusive=False)
        self.reset()

    def reset(self) -> None:
        """Forget the run: the next tick is the first (its storage is V_0, its work zero)."""
        self._effort: list[float] | None = None
        self._position: list[float] | None = None
        self.ticks = 0
        self.exchanged_work_j = 0.0
        self.initial_storage_j = 0.0
        self.storage_j = 0.0
        self.margin_j = 0.0
        self.min_margin_j = 0.0
        self.sampling_term_j = 0.0
        self.velocity_squared_integral = 0.0
        self.damping_needed = 0.0
        self.violation_ticks = 0
        self.last_violation_tick = -1

    @property
    def dof(self) -> int:
        return self._dof

    @property
    def shortfall_j(self) -> float:
        """The largest energy the port gave out beyond its storage over the run, held effort included [J] (>= 0)."""
        return max(0.0, -self.min_margin_j)

    def observe(self, effort: ArrayLike, position: ArrayLike, storage_j: float) -> bool:
        """One tick: the effort decided at this tick, the measured port coordinate, the storage there.

        The work booked is the previous tick's effort over the displacement since then (the effort given now acts
        from now on). Returns True if this tick is a violation (module docstring).
        """
        efforts = finite_floats("effort", effort, self._dof)
        positions = finite_floats("position", position, self._dof)
        storage = finite_scalar("storage_j", storage_j)
        if self._position is None:
            self.initial_storage_j = storage
        else:
            work = lag = squared = 0.0
            for now, before, held, previous in zip(positions, self._position, efforts, self._effort):
                step = now - before
                work += previous * step
                lag += (held - previous) * step
                squared += step * step
            self.exchanged_work_j += work
            self.sampling_term_j += lag
            self.velocity_squared_integral += squared / self.period_s
        self._effort, self._position = efforts, positions
        self.storage_j = storage
        margin = self.exchanged_work_j - (storage - self.initial_storage_j)
        self.margin_j = margin
        self.ticks += 1
        if margin < self.min_margin_j:
            self.min_margin_j = margin
        if margin < 0.0 and self.velocity_squared_integral > 0.0:
            self.damping_needed = max(self.damping_needed, -margin / self.velocity_squared_integral)
        violated = margin + self.sampling_term_j < -self.tolerance_j
        if violated:
            self.violation_ticks += 1
            self.last_violation_tick = self.ticks
        return violated

    def diagnostics(self) -> dict[str, str]:
        """The run's figures as strings, for a /diagnostics status's key-value pairs."""
        def number(value: float) -> str:
            return f"{value:.6g}" if math.isfinite(value) else str(value)
        return {"exchanged_work_j": number(self.exchanged_work_j), "storage_j": number(self.storage_j),
                "margin_j": number(self.margin_j), "min_margin_j": number(self.min_margin_j),
                "shortfall_j": number(self.shortfall_j), "sampling_term_j": number(self.sampling_term_j),
                "damping_needed": number(self.damping_needed), "violation_ticks": str(self.violation_ticks),
                "ticks": str(self.ticks), "tolerance_j": number(self.tolerance_j)}
