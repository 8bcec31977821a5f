"""A planner pose whose orientation is not four numbers at all (a number, None) is refused in one line and counted
as refused, as the first pose the replica hears and after good ones (replica_loop.add_planner_pose reuses the last good
quaternion's rotation for the same four numbers: nothing else may take that path)."""
from __future__ import annotations

import numpy as np
import pytest
from config_values import replica_loop_parameters

from fic_core.errors import FicInputError
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.replica_loop import ReplicaLoop

Q0, QD0 = np.array(NOMINAL_CONFIGURATION, dtype=float), np.zeros(7)


@pytest.mark.parametrize("after_a_good_one", [False, True])
@pytest.mark.parametrize("quaternion", [1.0, None])
def test_an_orientation_that_is_not_four_numbers_is_refused(quaternion, after_a_good_one: bool) -> None:
    loop = ReplicaLoop(replica_loop_parameters(answer_every_state=True))
    loop.joint_state(0.0, 0.0, Q0, QD0)
    position = loop.desired.update(0.001, 0.001).position.copy()
    if after_a_good_one:
        loop.add_planner_pose(500_000, position, (0.0, 0.0, 0.0, 1.0), 0.0005)
    good = loop.counts["planner_poses"]
    with pytest.raises(FicInputError, match="quaternion"):
        loop.add_planner_pose(1_000_000, position, quaternion, 0.001)
    assert loop.counts["rejected_planner_poses"] == 1 and loop.counts["planner_poses"] == good

