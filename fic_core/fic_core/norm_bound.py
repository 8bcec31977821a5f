"""A vector scaled down to a bound on its Euclidean norm, keeping its direction (the force and speed bounds of the
master, the haptic device, the operator's hand and the set-point hold)."""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray


def norm_bounded(vector: NDArray[np.float64], bound: float) -> NDArray[np.float64]:
    """``vector`` itself if its norm is at most ``bound``, else ``vector`` scaled to norm ``bound`` (a new array).

    The norm is math.sqrt(v.dot(v)), the value np.linalg.norm gives a 1-D float vector, without its dispatch cost
    on the 1 kHz tick."""
    norm = math.sqrt(float(vector.dot(vector)))
    return vector * (bound / norm) if norm > bound else vector
