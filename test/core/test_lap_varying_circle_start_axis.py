"""A LapVaryingCircle uses the plane axes Circle builds for the same normal (trajectories.py): at t = 0 and phase
0 it is at the point of the Circle of its first diameter, to the last bit, for a normal along an axis (where that
point lies exactly on a base axis through the centre) and a tilted one."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.trajectories import Circle, LapVaryingCircle


@pytest.mark.parametrize("normal", [(0.0, 0.0, 1.0), (0.0, 0.0, -2.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0),
                                    (0.3, -0.2, 0.9)])
def test_the_first_lap_starts_where_circle_starts(normal: tuple[float, float, float]) -> None:
    centre = np.array([0.5, 0.0, 0.0])
    laps = LapVaryingCircle(centre, [5.0, 4.0], [0.2, 0.18, 0.22], normal=normal, phase=0.0)
    start = laps.point(0.0)
    np.testing.assert_array_equal(start, Circle(centre, 0.2, 5.0, normal=normal, phase=0.0).point(0.0))
    if normal[2] != 0.0 and normal[0] == normal[1] == 0.0:   # in the xy plane: on the x axis through the centre
        assert start.tolist()[1:] == [0.0, 0.0]
