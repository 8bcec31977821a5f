"""fic_core.desired_pose anchored on the very tick the planner is first used (its first pose arrived, no update has
used it yet): x_d starts at the TCP and ONE give-back takes it to the raw set-point; the planner's first jump is not
started beside it, which, aligned with the anchor's, moved x_d away from the set-point's own motion at twice
resume_speed (the same contract as test_desired_pose.py's anchor after a running first jump)."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.desired_pose import DesiredPose, DesiredPoseParameters

START = np.array([0.3, 0.0, 0.5])
RESUME_SPEED = 0.1          # [m/s]
PLANNER_SPEED = 0.13        # [m/s]
DT = 0.001                  # [s]


@pytest.mark.parametrize("ahead", [0.05, -0.05])
def test_anchored_before_the_planners_first_use_x_d_gives_back_once(ahead: float) -> None:
    pose = DesiredPose(DesiredPoseParameters(resume_speed=RESUME_SPEED, set_point_extrapolation=0.0))
    pose.start(START, np.eye(3))
    # the set-point x_d'' + x_d' as the holds give it, without give-backs
    reference = DesiredPose(DesiredPoseParameters(resume_speed=RESUME_SPEED, set_point_extrapolation=0.0))
    reference.start(START + [-0.3, 0.0, 0.0], np.eye(3))
    tcp = START + [ahead, 0.0, 0.0]
    previous_position = previous_set_point = None
    worst = 0.0
    for tick in range(8000):
        now = tick * DT
        planner = START + [-0.3 + PLANNER_SPEED * now, 0.0, 0.0]   # 0.3 m behind the start pose, moving +x
        for desired in (pose, reference):
            desired.add_planner_pose(int(round(now * 1e9)), planner, np.eye(3), now)
        if tick == 0:
            pose.anchor(tcp)
        position = pose.update(now, DT).position
        set_point = reference.update(now, DT).position
        if tick == 0:
            np.testing.assert_allclose(position, tcp)     # this tick: the TCP itself
        else:
            relative = np.linalg.norm((position - previous_position) - (set_point - previous_set_point)) / DT
            worst = max(worst, relative)
        previous_position, previous_set_point = position, set_point
    assert worst <= RESUME_SPEED + 1e-6, f"x_d moved from the set-point at {worst:.4f} m/s"
    np.testing.assert_allclose(previous_position, previous_set_point, atol=1e-9)
    assert not pose.anchored
