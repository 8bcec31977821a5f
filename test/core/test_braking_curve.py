"""The postural optimisation's braking curve (docs/CONTROL_LAWS.md) holds for every positive braking deceleration:
the velocity from which a joint still stops before its limit, braking at a after the lag L (horizon plus torque
ramp), meets v L + v^2 / 2a = room. A gentle deceleration (below 1 rad/s^2, a slow or heavily loaded arm's) is a
deceleration like any other; zero or a negative one, which could never stop a joint, is refused."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.errors import FicInputError
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.postural_optimisation import BRAKING_TORQUE_RAMP, PosturalOptimisation


@pytest.mark.parametrize("deceleration", [0.25, 0.5, 1.0, 3.0, 12.0])
def test_the_braking_velocity_stops_within_the_room_for_any_positive_deceleration(limits,
                                                                                  deceleration: float) -> None:
    optimisation = PosturalOptimisation(limits, 0.002, braking_deceleration=deceleration)
    np.testing.assert_array_equal(optimisation.braking_deceleration, np.full(7, deceleration))
    q = NOMINAL_CONFIGURATION.copy()
    lag = optimisation.horizon + BRAKING_TORQUE_RAMP
    low, high = optimisation.braking_velocity(q)
    for velocity, room in ((high, limits.upper_array - q), (-low, q - limits.lower_array)):
        assert np.all(velocity > 0.0)
        np.testing.assert_allclose(velocity * lag + velocity ** 2 / (2.0 * deceleration), room, rtol=1e-9)


@pytest.mark.parametrize("deceleration", [0.0, -1.0, [5.0, 5.0, 5.0, 0.0, 5.0, 5.0, 5.0]])
def test_a_deceleration_that_cannot_stop_a_joint_is_refused(limits, deceleration) -> None:
    with pytest.raises(FicInputError):
        PosturalOptimisation(limits, 0.002, braking_deceleration=deceleration)
