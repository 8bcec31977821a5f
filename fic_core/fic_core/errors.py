"""Errors and input checks shared by every fic_core module.

Every public function validates its inputs so that a NaN from a sensor or a
malformed parameter becomes a clear exception at the boundary instead of a
silently unstable robot.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

_FLOAT64 = np.dtype(np.float64)
_SHORT_VECTOR = 16  # up to this many elements, Python's sum of floats beats numpy's reduction


class FicInputError(ValueError):
    """A parameter or a signal given to fic_core is invalid (NaN, Inf, out of range, wrong shape)."""


def finite_array(name: str, value: ArrayLike, shape: tuple[int, ...] | None = None) -> NDArray[np.float64]:
    """Return ``value`` as a float64 array, raising FicInputError if it is not finite or has the wrong shape."""
    if type(value) is np.ndarray and value.dtype is _FLOAT64 and value.shape == shape and value.ndim == 1 \
            and value.size <= _SHORT_VECTOR:
        # The 1 kHz tick's common case, a short float vector (what np.asarray would return as it is): one sum of
        # Python floats, which any NaN or Inf propagates into, at a third of the cost of np.isfinite(...).all();
        # a sum that is not finite (or a huge finite input that overflowed it) takes the full check below.
        if math.isfinite(sum(value.tolist())):
            return value
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise FicInputError(f"{name} must be numeric, got {value!r}") from exc
    if shape is not None and array.shape != shape:
        raise FicInputError(f"{name} must have shape {shape}, got {array.shape}")
    if not np.isfinite(array).all():   # the method: np.all's dispatch costs more than the test on the 1 kHz tick
        raise FicInputError(f"{name} must be finite, got {array}")
    return array


def finite_scalar(name: str, value: float, *, minimum: float | None = None, maximum: float | None = None,
                  minimum_inclusive: bool = True, maximum_inclusive: bool = True) -> float:
    """Return ``value`` as a float, raising FicInputError naming ``name`` if it is not finite or out of range."""
    try:
        number = float(value)
    except (TypeError, ValueError) as exc:
        raise FicInputError(f"{name} must be a number, got {value!r}") from exc
    if not math.isfinite(number):
        raise FicInputError(f"{name} must be finite, got {number}")
    if minimum is not None and (number < minimum or (not minimum_inclusive and number == minimum)):
        bound = ">=" if minimum_inclusive else ">"
        raise FicInputError(f"{name} must be {bound} {minimum}, got {number}")
    if maximum is not None and (number > maximum or (not maximum_inclusive and number == maximum)):
        bound = "<=" if maximum_inclusive else "<"
        raise FicInputError(f"{name} must be {bound} {maximum}, got {number}")
    return number


def finite_floats(name: str, value: ArrayLike, size: int) -> list[float]:
    """``finite_array`` for a short 1-D signal on the 1 kHz tick, returned as a list of Python floats.

    Per-axis logic on 3- or 6-vectors is cheaper in plain floats than in numpy (each numpy call costs about a
    microsecond of overhead). The common case (a float ndarray or a list of floats of the right length) is
    checked with one sum, which any NaN or Inf propagates into; anything else, or a sum that is not finite,
    takes ``finite_array``, which raises FicInputError naming ``name`` (or returns, if a huge but finite input
    overflowed the sum).
    """
    if type(value) is np.ndarray and value.shape == (size,) and value.dtype.kind == "f":
        values = value.tolist()
    elif type(value) is list and len(value) == size and all(type(item) is float for item in value):
        values = list(value)  # a copy: the caller may reuse its list
    else:
        return finite_array(name, value, (size,)).tolist()
    if not math.isfinite(sum(values)):
        return finite_array(name, values, (size,)).tolist()
    return values
