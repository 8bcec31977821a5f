"""A passivity observer: per axis, the work done on a controller's port and its storage, tick by tick.

The port of one FIC axis is the pair (error e, force F). Ryu and Hannaford's passivity observer sums the energy
that flows into a port, sample by sample; here the sum is the one the attractor's passivity argument uses
(docs/CONTROL_LAWS.md, "Passivity of the attractor"): the force returned at a tick times the displacement that
led to it,

    W_k = sum_{j=1..k} F_j (e_j - e_{j-1}) ,       margin_k = W_k - (V_k - V_0) ,

with V the controller's storage. A passive controller keeps every margin >= 0 (it never gives out more energy
than it took in); the observer counts the ticks where a margin is below ``-tolerance`` as violations. The margin
is non-decreasing for the FIC (each tick adds its dissipation), so the smallest margin over a run is the figure
that judges it. The observer only reads: it changes nothing in the controller.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from fic_core.errors import FicInputError, finite_scalar

#: Margin below which a tick counts as a violation [J]: far above the rounding of the storage (~1e-15 J), far
#: below any energy that matters on an arm (1 mm against 10 N is 1e-2 J).
DEFAULT_TOLERANCE = 1e-6


class PortSnapshot(Protocol):
    """What the observer reads of a controller's tick (attractor and baseline snapshots provide it)."""

    def port_values(self) -> tuple[Sequence[float], Sequence[float], Sequence[float]]:
        """(errors, forces, storages) per axis at this tick."""
        ...


class PassivityObserver:
    """Port work, storage and passivity margin per axis (module docstring)."""

    def __init__(self, axes: int, tolerance: float = DEFAULT_TOLERANCE) -> None:
        if isinstance(axes, bool) or not isinstance(axes, (int, np.integer)) or axes < 1:
            raise FicInputError(f"axes must be a positive integer, got {axes!r}")
        self._axes = int(axes)
        self.tolerance = finite_scalar("tolerance", tolerance, minimum=0.0)
        self.reset()

    def reset(self) -> None:
        """Forget the run: the next tick is the first (its storage is V_0, its work zero)."""
        self._previous_errors: list[float] | None = None
        self._work = [0.0] * self._axes
        self._initial_storage = [0.0] * self._axes
        self._storage = [0.0] * self._axes
        self._margins = [0.0] * self._axes
        self.ticks = 0
        self.violation_ticks = 0
        #: The smallest margin over the run and the axes [J] (0 before the first tick).
        self.min_margin = 0.0

    def restart_port(self) -> None:
        """The controller was replaced or reset (its storage restarts): the next tick starts a new sum, while the
        run's smallest margin and violation count are kept (the port work of the new sum is its own)."""
        self._previous_errors = None
        self._work = [0.0] * self._axes

    @property
    def axes(self) -> int:
        return self._axes

    def observe(self, errors: Sequence[float], forces: Sequence[float], storages: Sequence[float]) -> bool:
        """One tick: add F_k (e_k - e_{k-1}) to each axis's work; returns True if a margin is below -tolerance."""
        if len(errors) != self._axes or len(forces) != self._axes or len(storages) != self._axes:
            raise FicInputError(f"the observer has {self._axes} axes, got {len(errors)} errors, {len(forces)} "
                                f"forces and {len(storages)} storages")
        previous = self._previous_errors
        if previous is None:
            self._initial_storage = list(storages)
            previous = errors
        work = self._work
        initial = self._initial_storage
        margins = []
        for axis, (error, before, force, storage) in enumerate(zip(errors, previous, forces, storages)):
            work[axis] += force * (error - before)
            margins.append(work[axis] - (storage - initial[axis]))
        self._previous_errors = list(errors)
        self._storage = list(storages)
        self._margins = margins
        self.ticks += 1
        smallest = min(margins)
        if smallest < self.min_margin:
            self.min_margin = smallest
        violated = smallest < -self.tolerance
        if violated:
            self.violation_ticks += 1
        return violated

    def observe_snapshot(self, snapshot: PortSnapshot) -> bool:
        """``observe`` on a controller's snapshot of one tick."""
        return self.observe(*snapshot.port_values())

    @property
    def port_work(self) -> NDArray[np.float64]:
        """W per axis since the first tick [J]."""
        return np.array(self._work, dtype=np.float64)

    @property
    def storage(self) -> NDArray[np.float64]:
        """V per axis at the last tick [J]."""
        return np.array(self._storage, dtype=np.float64)

    @property
    def margin(self) -> NDArray[np.float64]:
        """W - (V - V_0) per axis at the last tick [J]."""
        return np.array(self._margins, dtype=np.float64)
