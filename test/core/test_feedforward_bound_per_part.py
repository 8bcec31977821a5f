"""The feedforward's bound (``feedforward_limit`` (F, M), replica.py's module docstring: "the force and the moment of
Lambda a_d are clipped to norms") holds each part on its own: a feedforward whose force is within F and whose moment
is past M has its moment scaled to exactly M, in its direction, and its force left as it is; and the other way
round; and so whichever of F and M is the larger, over seeded feedforwards and bounds drawn independently (F below
M, above it, either part past its bound or both). The unbounded controller's feedforward is the reference."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel

LIMIT = (15.0, 5.0)  # [N, N m]; at the nominal configuration 60 rad/s^2 about z asks 12.1 N and 6.5 N m, 5 m/s^2
# along z 33.4 N and 4.5 N m


def _feedforward(robot: RobotModel, limit: tuple[float, float] | None, acceleration: np.ndarray) -> np.ndarray:
    robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    position, rotation = robot.tcp_position.copy(), robot.tcp_rotation.copy()
    law = PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 30.0), ForceProfile(20.0, 0.5, 0.5, 10.0))
    command = ReplicaController(robot, law, feedforward_limit=limit).command(
        NOMINAL_CONFIGURATION, np.zeros(7), position, rotation, None, acceleration)
    return command.feedforward_wrench


@pytest.mark.parametrize("acceleration", [[0.0, 0.0, 0.0, 0.0, 0.0, 60.0], [0.0, 0.0, 5.0, 0.0, 0.0, 0.0]],
                         ids=["moment past its bound", "force past its bound"])
def test_each_part_of_the_feedforward_is_bounded_on_its_own(robot: RobotModel, acceleration: list[float]) -> None:
    free = _feedforward(robot, None, np.array(acceleration))
    bounded = _feedforward(robot, LIMIT, np.array(acceleration))
    for part, bound in ((slice(0, 3), LIMIT[0]), (slice(3, 6), LIMIT[1])):
        norm = np.linalg.norm(free[part])
        if norm <= bound:
            np.testing.assert_array_equal(bounded[part], free[part])
        else:
            np.testing.assert_allclose(bounded[part], free[part] * (bound / norm), rtol=1e-12, atol=1e-12)
    past = [np.linalg.norm(free[:3]) > LIMIT[0], np.linalg.norm(free[3:]) > LIMIT[1]]
    assert past == [False, True] if acceleration[5] else past == [True, False]


def test_each_part_is_held_to_its_own_norm_whichever_bound_is_the_larger(robot: RobotModel) -> None:
    rng = np.random.default_rng(909)
    cases = {"force past F within M": 0, "moment past M within F": 0, "both past": 0, "both within": 0}
    for _ in range(48):
        acceleration = rng.normal(size=6) * np.concatenate([np.full(3, rng.choice([0.3, 3.0])),
                                                            np.full(3, rng.choice([3.0, 30.0]))])
        free = _feedforward(robot, None, acceleration)
        norms = (float(np.linalg.norm(free[:3])), float(np.linalg.norm(free[3:])))
        # Each bound drawn around one of the two norms, so that F < M and F > M both come up with either part
        # past its bound.
        limit = (float(rng.choice(norms) * rng.uniform(0.3, 1.7)), float(rng.choice(norms) * rng.uniform(0.3, 1.7)))
        bounded = _feedforward(robot, limit, acceleration)
        past = []
        for part, norm, bound in ((slice(0, 3), norms[0], limit[0]), (slice(3, 6), norms[1], limit[1])):
            if norm <= bound:
                np.testing.assert_array_equal(bounded[part], free[part])
            else:
                np.testing.assert_allclose(bounded[part], free[part] * (bound / norm), rtol=1e-12, atol=0.0)
                assert np.linalg.norm(bounded[part]) <= bound * (1.0 + 1e-12)
            past.append(norm > bound)
        if past == [True, False] and norms[0] <= limit[1]:
            cases["force past F within M"] += 1
        elif past == [False, True] and norms[1] <= limit[0]:
            cases["moment past M within F"] += 1
        elif all(past):
            cases["both past"] += 1
        elif not any(past):
            cases["both within"] += 1
    assert min(cases.values()) >= 3, cases
