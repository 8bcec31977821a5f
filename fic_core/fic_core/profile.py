"""The FIC force profile F_c (paper Eq. 1, with the errata of docs/CONTROL_LAWS.md).

Per axis, for an error ``e = x_d - x`` with ``a = |e|`` and ``s = sign(e)``::

    F0 = xi*K0*x_b ;  dF = F_max - F0 ;  S = (1 - xi) * x_b / (2*pi)       [metres]
    F_c(e) = K0*e                                                           if a <= xi*x_b
           = s * (F0 + dF * (tanh((a - x_b)/S + pi) - tanh(-pi)) / (1 - tanh(-pi)))   otherwise

Two errata of the printed Eq. 1 are applied (docs/CONTROL_LAWS.md):

* the tanh argument is ``(a - x_b)/S + pi`` (the paper divides by ``S*x_b``, which has units of m^2), so
  that it runs from -pi at ``a = xi*x_b`` to +pi at ``a = x_b``;
* the tanh term is renormalised by ``(tanh(u) - tanh(-pi)) / (1 - tanh(-pi))``, so that the profile is
  continuous at ``xi*x_b`` (the printed one jumps by about 0.19 % of dF there) and tends to exactly F_max.

The FIC's stability proof only needs F_c to be Lipschitz (paper Sec. II-A); ``lipschitz_bound`` gives a
proven bound on |dF_c/de| and ``energy`` the spring's potential, used as stored energy by the attractor.
The profile is odd, monotonically non-decreasing in ``e``, and bounded by F_max.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.errors import FicInputError, finite_array, finite_scalar

#: tanh(-pi): the value of the profile's tanh at the start of the saturation (a = xi*x_b).
_TANH_START = math.tanh(-math.pi)
#: Normaliser of the tanh term so that it runs from exactly 0 (at xi*x_b) to 1 (a -> infinity).
_TANH_SPAN = 1.0 - _TANH_START


def _log_cosh(u: NDArray[np.float64]) -> NDArray[np.float64]:
    """log(cosh(u)) without overflow for large |u|."""
    magnitude = np.abs(u)
    return magnitude + np.log1p(np.exp(-2.0 * magnitude)) - math.log(2.0)


@dataclass(frozen=True)
class ForceProfile:
    """Parameters of the force profile F_c of paper Eq. 1, validated on construction.

    Attributes:
        stiffness: K0 [N/m, or N m/rad for rotation], the stiffness of the linear region.
        saturation_error: x_b [m or rad], the error at which the force saturates.
        saturation_start: xi in [0, 1), the fraction of x_b where the saturation starts.
        max_force: F_max [N or N m] >= F0 = xi*K0*x_b, the force the profile tends to.
    """

    stiffness: float
    saturation_error: float
    saturation_start: float
    max_force: float

    def __post_init__(self) -> None:
        stiffness = finite_scalar("stiffness", self.stiffness, minimum=0.0, minimum_inclusive=False)
        saturation_error = finite_scalar("saturation_error", self.saturation_error, minimum=0.0,
                                         minimum_inclusive=False)
        saturation_start = finite_scalar("saturation_start", self.saturation_start, minimum=0.0)
        if saturation_start >= 1.0:
            # xi = 1 makes S = 0: the tanh would be a step, the profile discontinuous and not Lipschitz.
            raise FicInputError(
                f"saturation_start (xi) must be < 1 (xi = 1 makes the saturation width S zero and the profile "
                f"discontinuous), got {saturation_start}")
        max_force = finite_scalar("max_force", self.max_force, minimum=0.0, minimum_inclusive=False)
        linear_limit_force = saturation_start * stiffness * saturation_error
        if max_force < linear_limit_force:
            raise FicInputError(
                f"max_force must be >= F0 = saturation_start*stiffness*saturation_error = {linear_limit_force}, "
                f"got {max_force}")
        # Store plain floats so that numpy scalars or ints given by callers behave identically.
        object.__setattr__(self, "stiffness", stiffness)
        object.__setattr__(self, "saturation_error", saturation_error)
        object.__setattr__(self, "saturation_start", saturation_start)
        object.__setattr__(self, "max_force", max_force)
        # Derived constants, computed once here rather than on every call of the 1 kHz tick (not dataclass
        # fields: equality, hashing and repr still use the four parameters only).
        width = (1.0 - saturation_start) * saturation_error / (2.0 * math.pi)
        force_span = max_force - linear_limit_force
        object.__setattr__(self, "_linear_limit", saturation_start * saturation_error)
        object.__setattr__(self, "_linear_limit_force", linear_limit_force)
        object.__setattr__(self, "_force_span", force_span)  # dF = F_max - F0
        object.__setattr__(self, "_width", width)  # S
        object.__setattr__(self, "_tangent_slope", force_span * (1.0 - _TANH_START ** 2) / (_TANH_SPAN * width))
        object.__setattr__(self, "_linear_energy", 0.5 * stiffness * (saturation_start * saturation_error) ** 2)

    @property
    def linear_limit(self) -> float:
        """xi*x_b: the largest |e| where the profile is linear (K0*e)."""
        return self._linear_limit

    @property
    def linear_limit_force(self) -> float:
        """F0 = xi*K0*x_b: the force where the saturation starts."""
        return self._linear_limit_force

    @property
    def saturation_width(self) -> float:
        """S = (1 - xi)*x_b/(2*pi) [m]: the tanh's length scale (the erratum on units of Eq. 1)."""
        return self._width

    def force(self, error: ArrayLike) -> NDArray[np.float64]:
        """F_c(error), elementwise (paper Eq. 1)."""
        # The parameters were validated in __post_init__; only the signal needs checking here.
        return _profile_force(finite_array("error", error), self.stiffness, self.saturation_error,
                              self.saturation_start, self.max_force)

    def lipschitz_bound(self) -> float:
        """A proven bound L with |F_c(a) - F_c(b)| <= L*|a - b| for all a, b.

        The linear region has slope K0. In the saturation region
        dF_c/da = dF / (1 - tanh(-pi)) * sech^2(u) / S with sech^2 <= 1. F_c is continuous and piecewise C^1,
        so the larger of the two slopes bounds every difference quotient.
        """
        saturation_slope = (self.max_force - self.linear_limit_force) / (_TANH_SPAN * self.saturation_width)
        if self.linear_limit == 0.0:  # xi = 0: there is no linear region, K0 plays no part
            return saturation_slope
        return max(self.stiffness, saturation_slope)

    def secant_stiffness(self, error: ArrayLike) -> NDArray[np.float64]:
        """F_c(e)/e elementwise, with its limit dF_c/de(0) at e = 0 (no division by ~0).

        This is the stiffness of the line from the origin to the profile, used by the convergence
        law of Eq. 2, 2*F_c(e_max)/e_max.
        """
        error_array = finite_array("error", error)
        magnitude = np.abs(error_array)
        linear_limit = self.linear_limit
        # Just past xi*x_b the profile is F0 + (tangent slope)*(a - xi*x_b); at or below `tiny` the finite quotient
        # would lose its digits to the cancellation in tanh(u) - tanh(-pi), so that linearisation is used.
        tangent_slope = ((self.max_force - self.linear_limit_force) * (1.0 - _TANH_START ** 2)
                         / (_TANH_SPAN * self.saturation_width))
        tiny = 1e-9 * self.saturation_error
        safe = np.where(magnitude > 0.0, magnitude, 1.0)
        quotient = np.abs(self.force(safe)) / safe
        # For a subnormal magnitude inside the linear range this quotient overflows; np.where below then takes the
        # stiffness instead, so the overflow is harmless and not worth a warning.
        with np.errstate(over="ignore"):
            linearised = np.where(magnitude > 0.0,
                                  (self.linear_limit_force + tangent_slope * (magnitude - linear_limit)) / safe,
                                  tangent_slope)
        secant = np.where(magnitude > tiny, quotient, linearised)
        return np.where((magnitude <= linear_limit) & (linear_limit > 0.0), self.stiffness, secant)

    def energy(self, error: ArrayLike) -> NDArray[np.float64]:
        """The potential of the profile, integral of F_c from 0 to |error| (closed form), elementwise [J].

        Linear region: K0*a^2/2. Saturation region, with u = (a - x_b)/S + pi and a0 = xi*x_b:
        E(a0) + F0*(a - a0) + dF/(1 - tanh(-pi)) * (S*(log cosh(u) - log cosh(-pi)) - tanh(-pi)*(a - a0)).
        """
        error_array = finite_array("error", error)
        magnitude = np.abs(error_array)
        linear_limit = self.linear_limit
        width = self.saturation_width
        force_span = self.max_force - self.linear_limit_force
        beyond = np.maximum(magnitude - linear_limit, 0.0)
        argument = (np.maximum(magnitude, linear_limit) - self.saturation_error) / width + math.pi
        tanh_integral = width * (_log_cosh(argument) - _log_cosh(np.array(-math.pi))) - _TANH_START * beyond
        saturated = (0.5 * self.stiffness * linear_limit ** 2 + self.linear_limit_force * beyond
                     + force_span / _TANH_SPAN * tanh_integral)
        return np.where(magnitude <= linear_limit, 0.5 * self.stiffness * magnitude ** 2, saturated)

    # Scalar forms of force, secant_stiffness and energy for one axis, on plain floats that the caller has
    # validated (the attractor's per-axis loop): the same formulas, without numpy's per-call overhead on 3-vectors.
    # Nothing is checked here: a caller with unchecked input uses the array forms above.
    def scalar_force(self, error: float) -> float:
        """F_c(error) for one validated float (``force`` on one axis)."""
        magnitude = abs(error)
        if magnitude <= self._linear_limit:
            return self.stiffness * error
        saturated = self._linear_limit_force + self._force_span * (
            math.tanh((magnitude - self.saturation_error) / self._width + math.pi) - _TANH_START) / _TANH_SPAN
        return saturated if error > 0.0 else -saturated

    def scalar_secant_stiffness(self, error: float) -> float:
        """F_c(e)/e for one validated float (``secant_stiffness`` on one axis)."""
        magnitude = abs(error)
        linear_limit = self._linear_limit
        if magnitude <= linear_limit and linear_limit > 0.0:
            return self.stiffness
        if magnitude > 1e-9 * self.saturation_error:
            return abs(self.scalar_force(magnitude)) / magnitude
        if magnitude > 0.0:
            return (self._linear_limit_force + self._tangent_slope * (magnitude - linear_limit)) / magnitude
        return self._tangent_slope

    def scalar_energy(self, error: float) -> float:
        """V_D(|error|) for one validated float (``energy`` on one axis) [J]."""
        magnitude = abs(error)
        linear_limit = self._linear_limit
        if magnitude <= linear_limit:
            return 0.5 * self.stiffness * magnitude * magnitude
        width = self._width
        beyond = magnitude - linear_limit
        argument = (magnitude - self.saturation_error) / width + math.pi
        tanh_integral = width * (_scalar_log_cosh(argument) - _LOG_COSH_START) - _TANH_START * beyond
        return self._linear_energy + self._linear_limit_force * beyond + self._force_span / _TANH_SPAN * tanh_integral


    def energy_inverse(self, energy: float) -> float:
        """The error magnitude a >= 0 with V_D(a) = energy, rounded towards the smaller storage [m or rad].

        V_D is convex and increasing on a >= 0 (its slope F_c is non-decreasing and positive for a > 0), so the
        inverse is unique. It is rounded so that V_D(result) <= energy up to rounding: a D error matched to a given
        storage never holds more (the attractor's earlier dead-zone rule sized its zone with it).
        """
        return self._scalar_energy_inverse(finite_scalar("energy", energy, minimum=0.0))

    def _scalar_energy_inverse(self, energy: float) -> float:
        if energy <= 0.0:
            return 0.0
        if energy <= self._linear_energy:
            return math.sqrt(2.0 * energy / self.stiffness)  # the linear region: V_D = K0 a^2/2
        # Newton's method from above: on a convex increasing V_D every iterate stays above the root and the
        # sequence decreases to it quadratically. The start must be above the root: F_c >= F0 beyond xi x_b, so
        # V_D(a) >= V_D(xi x_b) + F0 (a - xi x_b) and a0 = xi x_b + (energy - V_D(xi x_b))/F0 is above it when
        # F0 > 0; with xi = 0 (F0 = 0) the start doubles from x_b until V_D there reaches the energy.
        linear_limit = self._linear_limit
        if self._linear_limit_force > 0.0:
            magnitude = linear_limit + (energy - self._linear_energy) / self._linear_limit_force
        else:
            magnitude = self.saturation_error
            while self.scalar_energy(magnitude) < energy:
                magnitude *= 2.0
        for _ in range(60):
            excess = self.scalar_energy(magnitude) - energy
            if excess <= 0.0:
                break
            step = excess / self.scalar_force(magnitude)
            magnitude -= step
            if step <= 1e-15 * magnitude:
                break
        # What Newton leaves above the root is far below this relative margin once it has converged: the result
        # is on the side of the smaller storage.
        return max(magnitude * (1.0 - 1e-12), linear_limit)


def _scalar_log_cosh(u: float) -> float:
    magnitude = abs(u)
    return magnitude + math.log1p(math.exp(-2.0 * magnitude)) - _LOG_2


_LOG_2 = math.log(2.0)
_LOG_COSH_START = _scalar_log_cosh(-math.pi)


def force_profile(error: ArrayLike, *, stiffness: float, saturation_error: float, saturation_start: float,
                  max_force: float) -> NDArray[np.float64]:
    """F_c(error) of paper Eq. 1 with its errata (docs/CONTROL_LAWS.md), elementwise; odd, continuous, tends to
    max_force.

    Args:
        error: e = x_d - x per axis [m or rad], any shape.
        stiffness: K0 > 0.
        saturation_error: x_b > 0.
        saturation_start: xi in [0, 1).
        max_force: F_max >= xi*K0*x_b.
    """
    error_array = finite_array("error", error)
    stiffness = finite_scalar("stiffness", stiffness, minimum=0.0, minimum_inclusive=False)
    saturation_error = finite_scalar("saturation_error", saturation_error, minimum=0.0, minimum_inclusive=False)
    saturation_start = finite_scalar("saturation_start", saturation_start, minimum=0.0, maximum=1.0,
                                     maximum_inclusive=False)
    max_force = finite_scalar("max_force", max_force, minimum=0.0, minimum_inclusive=False)
    if max_force < saturation_start * stiffness * saturation_error:
        raise FicInputError(f"max_force must be >= F0 = saturation_start*stiffness*saturation_error = "
                            f"{saturation_start * stiffness * saturation_error}, got {max_force}")
    return _profile_force(error_array, stiffness, saturation_error, saturation_start, max_force)


def _profile_force(error: NDArray[np.float64], stiffness: float, saturation_error: float, saturation_start: float,
                   max_force: float) -> NDArray[np.float64]:
    """Eq. 1 on already validated inputs."""
    linear_limit_force = saturation_start * stiffness * saturation_error  # F0
    linear_limit = saturation_start * saturation_error  # xi*x_b
    width = (1.0 - saturation_start) * saturation_error / (2.0 * math.pi)  # S
    magnitude = np.abs(error)
    # Eq. 1, second line (errata applied): tanh from -pi at a = xi*x_b to +pi at a = x_b, renormalised.
    argument = (magnitude - saturation_error) / width + math.pi
    saturated = linear_limit_force + (max_force - linear_limit_force) * (np.tanh(argument) - _TANH_START) / _TANH_SPAN
    return np.where(magnitude <= linear_limit, stiffness * error, np.sign(error) * saturated)
