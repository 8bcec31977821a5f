"""fic_core.desired_pose at the anchor after the loop's hold: x_d starts at the TCP and ONE give-back takes it to the
raw set-point. The give-backs still running at the anchor (here the planner's first jump) end there; left running
beside the new one, two aligned give-backs moved x_d away from the set-point's own motion at twice resume_speed
(a starvation stress run: the arm, starting from rest, fell 95-99 mm behind)."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.desired_pose import DesiredPose, DesiredPoseParameters
from fic_core.errors import FicInputError

START = np.array([0.3, 0.0, 0.5])
RESUME_SPEED = 0.1          # [m/s]
PLANNER_SPEED = 0.13        # [m/s] about the paper's circle (0.126 m/s)
DT = 0.001                  # [s] the control tick
ANCHOR_TICK = 1000          # the planner's first jump (0.3 m) is 0.2 m from done then


def test_at_the_anchor_x_d_moves_from_the_set_points_own_motion_at_resume_speed_at_most() -> None:
    pose = DesiredPose(DesiredPoseParameters(resume_speed=RESUME_SPEED, set_point_extrapolation=0.0))
    pose.start(START, np.eye(3))
    # the set-point x_d'' + x_d' as the holds give it, without give-backs: a pose started on the planner's first pose
    reference = DesiredPose(DesiredPoseParameters(resume_speed=RESUME_SPEED, set_point_extrapolation=0.0))
    reference.start(START + [-0.3, 0.0, 0.0], np.eye(3))
    previous_position = previous_set_point = None
    worst_after_anchor = 0.0
    for tick in range(6000):
        now = tick * DT
        # the planner starts 0.3 m behind the start pose (-x) and moves along +x: its first jump is given back along
        # +x, the same way as the anchor's difference below (the two aligned, as in the stress run)
        planner = START + [-0.3 + PLANNER_SPEED * now, 0.0, 0.0]
        for desired in (pose, reference):
            desired.add_planner_pose(int(round(now * 1e9)), planner, np.eye(3), now)
        if tick == ANCHOR_TICK:
            tcp = previous_position + [0.05, 0.0, 0.0]   # the arm, held, is 50 mm ahead of x_d (+x)
            pose.anchor(tcp)
        position = pose.update(now, DT).position
        set_point = reference.update(now, DT).position
        if tick == ANCHOR_TICK:
            np.testing.assert_allclose(position, tcp)     # this tick: the TCP itself
        elif tick > ANCHOR_TICK:
            relative_speed = np.linalg.norm((position - previous_position) - (set_point - previous_set_point)) / DT
            worst_after_anchor = max(worst_after_anchor, relative_speed)
        previous_position, previous_set_point = position, set_point
    assert worst_after_anchor <= RESUME_SPEED + 1e-6, f"x_d moved from the set-point at {worst_after_anchor:.4f} m/s"
    np.testing.assert_allclose(previous_position, previous_set_point, atol=1e-9)   # and it reached the set-point
    assert not pose.anchored


def test_by_default_x_d_holds_the_start_orientation_and_the_planners_only_when_asked() -> None:
    """The planner plans positions: unless use_planner_orientation is set (config/replica.yaml ships it off),
    R_d is the start orientation whatever orientation the planner's poses carry; set, it is the planner's."""
    turned = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])   # 90 deg about z
    start = np.eye(3)
    for parameters, expected in ((DesiredPoseParameters(), start),
                                 (DesiredPoseParameters(use_planner_orientation=True), turned)):
        pose = DesiredPose(parameters)
        pose.start(START, start)
        pose.add_planner_pose(0, START, turned, 0.0)
        np.testing.assert_array_equal(pose.update(0.001, DT).rotation, expected)


def test_x_d_prime_goes_stale_strictly_after_master_timeout_says_so_once_and_is_held() -> None:
    """No teleoperation command for more than master_timeout (by receipt): x_d' is held where it was, with one
    notice naming the timeout; a tick exactly master_timeout after the last command is not stale yet. The command
    before it was given back from 0 at resume_speed, and the first tick that used it recorded its age."""
    pose = DesiredPose(DesiredPoseParameters(master_timeout=0.5, resume_speed=RESUME_SPEED,
                                             offset_feedforward=False))
    pose.start(START, np.eye(3))
    assert not pose.command_unused
    pose.add_teleoperation(int(0.25e9), [0.02, 0.0, 0.0], now=0.25)   # sampled at 0.25 s, received at 0.25 s
    assert pose.command_unused and pose.resuming
    first = pose.update(0.3, DT)
    assert not pose.command_unused
    assert pose.master_first_use_age == 0.3 - 0.25
    np.testing.assert_allclose(first.position, START + [RESUME_SPEED * DT, 0.0, 0.0], rtol=1e-12)
    for tick in range(1, 401):                      # to 0.7 s
        sample = pose.update(0.3 + tick * DT, DT)
    np.testing.assert_allclose(sample.position, START + [0.02, 0.0, 0.0], atol=1e-12)   # given back, 0.2 s
    assert not pose.resuming and not pose.master_stale and sample.notices == []
    assert pose.update(0.75, DT).notices == [] and not pose.master_stale   # exactly 0.5 s after: not stale
    stale = pose.update(0.75 + 1e-6, DT)
    assert pose.master_stale and len(stale.notices) == 1 and "master_timeout = 0.5 s" in stale.notices[0]
    later = pose.update(5.0, DT)
    assert later.notices == []
    np.testing.assert_allclose(later.position, START + [0.02, 0.0, 0.0], atol=1e-12)
    notice = pose.add_teleoperation(int(5.0e9), [0.05, 0.0, 0.0], now=5.0)
    assert notice is not None and "back" in notice and not pose.master_stale
    np.testing.assert_allclose(pose.update(5.001, DT).position, START + [0.02 + RESUME_SPEED * DT, 0.0, 0.0],
                               rtol=1e-9)


def test_no_desired_pose_before_the_start_pose_and_bad_samples_change_nothing() -> None:
    pose = DesiredPose()
    with pytest.raises(FicInputError, match="no start pose"):
        pose.update(0.0, DT)
    pose.start(START, np.eye(3))
    pose.add_teleoperation(0, [0.01, 0.0, 0.0], now=0.0)
    for bad in ([np.nan, 0.0, 0.0], [0.0, np.inf, 0.0]):
        with pytest.raises(FicInputError, match="desired_offset"):
            pose.add_teleoperation(1_000_000, bad, now=0.001)
    assert pose.master_stamp_ns == 0 and pose.master_received == 0.0
