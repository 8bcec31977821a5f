"""A joint exactly on a position limit is inside its range, not past it (postural_optimisation.py's
acceleration_bounds: "past a limit: return, on the horizon"): the braking velocity there is zero and the range
leaves no room, so its velocity on the next sample may not point beyond the limit, qdd <= -qd/dt on the upper
limit (qdd >= -qd/dt on the lower), set by the position limit; the other side stays the velocity limit's, unless a
joint moving toward the limit cannot both stop and keep it (then the position side is kept, reconciled)."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.limits import PandaLimits
from fic_core.postural_optimisation import PosturalOptimisation


@pytest.mark.parametrize("dt", [0.001, 0.004])
@pytest.mark.parametrize("joint", [0, 3, 5])
def test_a_joint_on_its_limit_must_not_move_past_it_on_the_next_sample(limits: PandaLimits, dt: float,
                                                                       joint: int) -> None:
    optimisation = PosturalOptimisation(limits, dt)
    horizon = optimisation.horizon
    assert horizon != dt
    v_max = limits.joint_velocity[joint]
    for side, sign in (("upper", 1.0), ("lower", -1.0)):
        for fraction in (0.25, 0.0, -0.25):            # toward the limit, at rest, away from it
            q = 0.5 * (limits.lower_array + limits.upper_array)
            q[joint] = (limits.upper_array if side == "upper" else limits.lower_array)[joint]
            qd = np.zeros(7)
            qd[joint] = sign * fraction * v_max
            low, high, low_by_position, high_by_position, reconciled = optimisation.acceleration_bounds(q, qd)
            stop = -qd[joint] / dt                        # the next sample's velocity 0
            toward = (sign * v_max - qd[joint]) / horizon   # the velocity limit on the limit's side
            away = (-sign * v_max - qd[joint]) / horizon    # and on the other
            near_by_position = sign * (toward - stop) > 0.0
            near = stop if near_by_position else toward
            # Moving toward the limit, stopping on the next sample asks more than the velocity limit allows the
            # other way: the position side is kept (both bounds the stop), reported reconciled.
            conflict = sign * (away - near) > 0.0
            assert conflict == (fraction > 0.0) and near_by_position == (fraction >= 0.0)
            bounds = (high, low) if side == "upper" else (low, high)
            by_position = (high_by_position, low_by_position) if side == "upper" else (low_by_position,
                                                                                      high_by_position)
            assert bounds[0][joint] == pytest.approx(near, rel=1e-12, abs=1e-9)
            assert bounds[1][joint] == pytest.approx(near if conflict else away, rel=1e-12, abs=1e-9)
            assert (by_position[0][joint], by_position[1][joint]) == (near_by_position, False)
            assert reconciled == conflict
