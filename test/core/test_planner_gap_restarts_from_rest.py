"""A planner sample gap longer than a tenth of a second (desired_pose.py: the planner publishes at 100 Hz) restarts
x_d'''s velocity estimate from rest, so after the gap x_d'' settles exactly on the sample; after a shorter gap the
estimate is the slope over the gap and the first-order hold carries x_d'' past the sample for the extrapolation time."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.desired_pose import DesiredPose, DesiredPoseParameters

START = np.array([0.3, 0.0, 0.5])
SPEED = 0.1          # [m/s] along +x
EXTRAPOLATION = 0.015


def settled_past_the_last_sample(gap: float) -> float:
    pose = DesiredPose(DesiredPoseParameters(set_point_extrapolation=EXTRAPOLATION))
    pose.start(START, np.eye(3))
    stamps = [0.01 * index for index in range(20)] + [0.19 + gap]
    position = START
    tick = 0
    for stamp in stamps:
        position = START + [SPEED * stamp, 0.0, 0.0]
        pose.add_planner_pose(round(stamp * 1e9), position, np.eye(3), stamp)
        while tick * 0.002 < stamp + 0.01:
            pose.update(tick * 0.002, 0.002)
            tick += 1
    for _ in range(200):   # long after every hold and blend has ended
        sample = pose.update(tick * 0.002, 0.002)
        tick += 1
    return float(sample.position[0] - position[0])


@pytest.mark.parametrize("gap", [0.11, 0.3, 1.5])
def test_after_a_gap_longer_than_a_tenth_of_a_second_x_d_settles_on_the_sample(gap: float) -> None:
    assert settled_past_the_last_sample(gap) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("gap", [0.02, 0.09])
def test_after_a_shorter_gap_x_d_moves_on_along_the_slope(gap: float) -> None:
    assert settled_past_the_last_sample(gap) == pytest.approx(SPEED * EXTRAPOLATION, rel=1e-6)
