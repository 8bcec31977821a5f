"""DesiredPose.has_planner, what the replica's diagnostics report as the planner's state ("no pose yet (holding the
start pose)" until then): false from the start, also after the start pose and a teleoperation command, true from
the first planner pose on; a refused planner pose leaves it false."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.desired_pose import DesiredPose, DesiredPoseParameters
from fic_core.errors import FicInputError


def test_has_planner_is_true_from_the_first_planner_pose_on() -> None:
    pose = DesiredPose(DesiredPoseParameters())
    assert not pose.has_planner
    pose.start(np.array([0.3, 0.0, 0.5]), np.eye(3))
    pose.add_teleoperation(0, [0.01, 0.0, 0.0], 0.0)
    assert not pose.has_planner
    with pytest.raises(FicInputError):
        pose.add_planner_pose(0, [np.nan, 0.0, 0.5], np.eye(3), 0.0)
    assert not pose.has_planner
    pose.add_planner_pose(0, [0.3, 0.0, 0.5], np.eye(3), 0.0)
    assert pose.has_planner
    pose.update(0.002, 0.002)
    assert pose.has_planner
