"""The arm's joints picked by name out of a joint-state message (any order, extra joints such as fingers)."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from .errors import FicInputError
from .panda_description import ARM_JOINT_NAMES


class JointOrder:
    """Index of each arm joint in a message's name list, cached per name list (a stream keeps its order)."""

    def __init__(self, names: Sequence[str] = ARM_JOINT_NAMES) -> None:
        self.names = tuple(names)
        self._cache: dict[tuple[str, ...], NDArray[np.intp]] = {}

    def pick(self, names: Sequence[str], positions: Sequence[float], velocities: Sequence[float]
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(q, qd) of the arm joints in this order; FicInputError if a joint is missing, the lengths disagree or
        a value is not finite."""
        key = tuple(names)
        index = self._cache.get(key)
        if index is None:
            try:
                index = np.array([key.index(name) for name in self.names])
            except ValueError:
                index = None
            if index is None:
                missing = [name for name in self.names if name not in key]
                raise FicInputError(f"joint names do not match: expected {list(self.names)}, received {list(key)} "
                                    f"(missing {missing}); set arm_type or joint_names to the driver's names")
            if len(positions) != len(key) or len(velocities) != len(key):
                raise FicInputError(f"joint state has {len(key)} names but {len(positions)} positions and "
                                    f"{len(velocities)} velocities (expected {list(self.names)}, received "
                                    f"{list(key)})")
            self._cache[key] = index
        if len(positions) != len(key) or len(velocities) != len(key):
            raise FicInputError(f"expected {len(key)} positions and velocities, got {len(positions)} and "
                                f"{len(velocities)}")
        q = np.asarray(positions, dtype=float)[index]
        qd = np.asarray(velocities, dtype=float)[index]
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
            raise FicInputError("positions or velocities are not finite")
        return q, qd
