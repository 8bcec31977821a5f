"""The FIC's storage computed on the observer's side: Eq. 1's potential by its own quadrature, applied to the phase
state the attractor declares, for the exchanged-energy observer (fic_core/exchanged_energy_observer.py).

Why not the attractor's own ``stored_energy``: an observer that books a controller against the controller's own
storage cannot fail. Why not the plain D potential V_D(|e|) of the error: the FIC is passive with respect to its
storage of the current phase (V_C inside C), and V_D(|e|) differs from that inside C, so a correct FIC
can be flagged (measured with the dead-zone rule of the time: 2,646 of 12,002 ticks on the push-release cycle at
0.02 m/s). So the storage here is the storage the passivity argument defines
(docs/CONTROL_LAWS.md, "Passivity of the attractor") evaluated from what the attractor declares it is doing, per
axis: its phase, e_max and K_C; the energies come from a cumulative trapezoid of ``ForceProfile.force``
(not the closed form, not ``latched_energies``): V_latch = V_D(e_max) at each latch, V_C the exact integral of the
clipped C line from there. The
effort the observer books is what was applied: if it is not the gradient of this storage (a non-conservative
field), or if the declared state jumps so that this storage rises at a switch (a non-passive switching rule), the
observer's margin falls.
"""
from __future__ import annotations

import numpy as np

from fic_core.attractor import AttractorSnapshot
from fic_core.errors import FicInputError
from fic_core.profile import ForceProfile


class ProfilePotential:
    """V_D(a) = integral_0^a F_c of Eq. 1 by a cumulative trapezoid of ``ForceProfile.force`` on a fine grid up to
    4 x_b (F_max beyond, where F_c is within 1e-10 of it). The grid's error is below 1e-8 of F_max x_b."""

    def __init__(self, profile: ForceProfile, points: int = 40_001) -> None:
        if not isinstance(profile, ForceProfile):
            raise FicInputError(f"profile must be a ForceProfile, got {type(profile).__name__}")
        self.profile = profile
        self._reach = 4.0 * profile.saturation_error
        self._grid = np.linspace(0.0, self._reach, points)
        forces = profile.force(self._grid)
        self._table = np.concatenate(([0.0], np.cumsum(0.5 * (forces[1:] + forces[:-1]) * np.diff(self._grid))))
        self._forces = forces

    def energy(self, magnitude: float) -> float:
        """V_D(max(magnitude, 0)) [J]."""
        magnitude = max(float(magnitude), 0.0)
        inside = min(magnitude, self._reach)
        index = min(int(inside / self._grid[1]), self._grid.size - 2)
        offset = inside - self._grid[index]
        slope = (self._forces[index + 1] - self._forces[index]) / self._grid[1]
        value = self._table[index] + self._forces[index] * offset + 0.5 * slope * offset * offset
        return float(value) + (magnitude - inside) * self.profile.max_force


def _clipped_line_integral(stiffness: float, centre: float, clip: float, start: float, end: float) -> float:
    """integral_start^end clip(K (s - centre), +-clip) ds, exact (the antiderivative of the clipped line)."""
    if stiffness <= 0.0:
        return 0.0

    def antiderivative(value: float) -> float:
        offset = value - centre
        width = clip / stiffness
        if abs(offset) <= width:
            return 0.5 * stiffness * offset * offset
        return clip * (abs(offset) - 0.5 * width)

    return antiderivative(end) - antiderivative(start)


class AttractorStorage:
    """Per-axis storage of a FractalAttractor's declared state, by the observer's own quadrature (module docstring).

    Call it once per tick with the attractor's snapshot of that tick, in order (it sees each latch happen and
    computes V_latch there).
    """

    def __init__(self, profile: ForceProfile) -> None:
        self.potential = ProfilePotential(profile)
        self.reset()

    def reset(self) -> None:
        self._previous_phase: tuple[bool, ...] | None = None
        self._previous_latched: tuple[float, ...] = ()
        self._latched_energies: list[float] = []

    def per_axis(self, snapshot: AttractorSnapshot) -> list[float]:
        """The storage of each axis at this tick [J]."""
        phases, latched, stiffnesses, errors = (snapshot.in_convergence, snapshot.latched_max_errors,
                                                 snapshot.convergence_stiffness, snapshot.errors)
        axes = len(errors)
        if self._previous_phase is None:
            self._previous_phase = (False,) * axes
            self._previous_latched = (0.0,) * axes
            self._latched_energies = [0.0] * axes
        max_force = self.potential.profile.max_force
        values = []
        for axis in range(axes):
            if phases[axis]:
                if not self._previous_phase[axis] or latched[axis] != self._previous_latched[axis]:
                    # D -> C (or a re-latch): V_latch is the D storage at e_max.
                    self._latched_energies[axis] = self.potential.energy(abs(latched[axis]))
                values.append(self._latched_energies[axis] + _clipped_line_integral(
                    stiffnesses[axis], 0.5 * latched[axis], max_force, latched[axis], errors[axis]))
            else:
                values.append(self.potential.energy(abs(errors[axis])))
        self._previous_phase, self._previous_latched = tuple(phases), tuple(latched)
        return values

    def __call__(self, snapshot: AttractorSnapshot) -> float:
        """The total storage over the axes at this tick [J]."""
        return float(sum(self.per_axis(snapshot)))
