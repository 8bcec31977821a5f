"""The per-axis laws take any positive number of axes, one included (their docstrings: a positive integer): the FIC
attractor (Eq. 2), the harmonic planner (Eqs. 5-6) and the sampled set-point run on one axis exactly as the first
axis of three does when the other two stay at zero (the axes are independent, and the norms the planner and the
set-point clip by are then that axis's magnitude); zero axes, a bool and a fraction are refused by name."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.attractor import FractalAttractor
from fic_core.errors import FicInputError
from fic_core.planner import HarmonicPlanner
from fic_core.profile import ForceProfile
from fic_core.set_point import SampledSetPoint

PROFILE = ForceProfile(200.0, 0.05, 0.5, 10.0)


def padded(value: float) -> list[float]:
    return [value, 0.0, 0.0]


def test_the_attractor_on_one_axis_is_the_first_axis_of_three() -> None:
    one, three = FractalAttractor(PROFILE, 1), FractalAttractor(PROFILE, 3)
    for k in range(400):   # out to 8 cm (saturation), back through zero (D -> C -> D)
        error = 0.08 * np.sin(0.02 * k)
        rate = 0.08 * 0.02 * np.cos(0.02 * k) / 0.001
        single = one.force([error], [rate])
        assert single.shape == (1,)
        assert single[0] == three.force(padded(error), padded(rate))[0]
    assert one.phase.tolist() == three.phase[:1].tolist()


def test_the_planner_on_one_axis_is_the_first_axis_of_three() -> None:
    one = HarmonicPlanner(8.0, 0.25, dimension=1)
    three = HarmonicPlanner(8.0, 0.25, dimension=3)
    for k in range(300):
        target = 0.1 if k < 150 else -0.05
        single = one.step([target], 0.01)
        assert single.shape == (1,)
        assert single[0] == three.step(padded(target), 0.01)[0]
    assert one.command_limits([0.2])[1][0] == three.command_limits(padded(0.2))[1][0]


def test_the_set_point_on_one_axis_is_the_first_axis_of_three() -> None:
    one, three = SampledSetPoint(1), SampledSetPoint(3)
    for k in range(30):   # a 2 m/s ramp sampled at 100 Hz: the speed clip (1 m/s) binds
        stamp = 0.01 * k
        one.add(stamp, [2.0 * stamp], stamp)
        three.add(stamp, padded(2.0 * stamp), stamp)
        now = stamp + 0.004
        for read in ("position", "velocity", "acceleration"):
            single = getattr(one, read)(now)
            assert single.shape == (1,)
            assert single[0] == getattr(three, read)(now)[0], read


@pytest.mark.parametrize("size", [0, -1, True, 1.0])
def test_no_axes_or_a_size_that_is_not_a_whole_number_is_refused(size) -> None:
    with pytest.raises(FicInputError, match="^axes must be a positive integer"):
        FractalAttractor(PROFILE, size)
    with pytest.raises(FicInputError, match="^dimension must be a positive integer"):
        HarmonicPlanner(8.0, 0.25, dimension=size)
    with pytest.raises(FicInputError, match="^dimension must be a positive integer"):
        SampledSetPoint(size)
