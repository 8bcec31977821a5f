"""Circle's normal is any vector of length 1e-9 or more (the plane is its direction): one exactly 1e-9 long along
each base axis (its norm is the component itself, to the bit) gives the circle of the unit normal along that
axis, point for point, and one a float shorter is refused by name, as the zero vector is."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.errors import FicInputError
from fic_core.trajectories import Circle

SHORTEST = 1e-9
CENTRE = np.array([0.4, 0.0, 0.3])


@pytest.mark.parametrize("axis", range(3))
def test_the_shortest_normal_is_taken_and_a_float_shorter_refused(axis: int) -> None:
    unit = np.zeros(3)
    unit[axis] = 1.0
    assert float(np.linalg.norm(SHORTEST * unit)) == SHORTEST
    shortest = Circle(CENTRE, 0.1, 4.0, normal=SHORTEST * unit)
    reference = Circle(CENTRE, 0.1, 4.0, normal=unit)
    for t in (0.0, 0.7, 2.5):
        np.testing.assert_allclose(shortest.point(t), reference.point(t), rtol=0.0, atol=1e-15)
    for normal in (float(np.nextafter(SHORTEST, 0.0)) * unit, np.zeros(3)):
        with pytest.raises(FicInputError, match="normal"):
            Circle(CENTRE, 0.1, 4.0, normal=normal)
