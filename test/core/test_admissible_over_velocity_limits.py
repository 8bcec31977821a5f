"""``admissible`` says VERDICT_INSIDE only if moreover every joint has |qd| <= v_max (its docstring; the replica
then skips the violation check): with every joint 1 % over its velocity limit, and tau_d bringing each back
inside on the horizon, the verdict is never INSIDE, in either order of its two tests, for either sign of qd."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.limits import PandaLimits
from fic_core.postural_optimisation import VERDICT_INSIDE, PosturalOptimisation

VELOCITY_HORIZON = 0.05   # [s] the optimisation's default T


@pytest.mark.parametrize("sign", [1.0, -1.0, "mixed"])
def test_every_joint_over_its_velocity_limit_is_never_inside(limits: PandaLimits, sign) -> None:
    signs = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0]) if sign == "mixed" else np.full(7, sign)
    v_max = limits.joint_velocity_array
    lower, upper = limits.lower_array, limits.upper_array
    q = 0.5 * (lower + upper)                     # mid-range: every joint far from its position limits
    qd = signs * 1.01 * v_max
    acceleration = -signs * 0.02 * v_max / VELOCITY_HORIZON   # qd + T qdd = 0.99 v_max on the horizon
    margins = np.minimum(q - lower, upper - q)
    desired = np.zeros(7)
    optimisation = PosturalOptimisation(limits, 0.001, velocity_horizon=VELOCITY_HORIZON)
    verdicts = [optimisation.admissible(desired.tolist(), None, q.tolist(), qd.tolist(), acceleration.tolist(),
                                        0.0, margins.tolist()) for _ in range(3)]
    assert VERDICT_INSIDE not in verdicts, verdicts
