"""The replica's link hold design set live (``interpolate_link_samples``, DesiredPose.parameters): a change of
design takes effect, x_d' then follows the new design as a pose started with it does, once the difference at the
switch is given back; new settings with the same design change nothing (the hold keeps its samples and x_d' goes on
bit for bit as if they had not been set)."""
from __future__ import annotations

import math

import numpy as np

from fic_core.desired_pose import DesiredPose, DesiredPoseParameters

PERIOD = 0.002      # [s] the replica's 500 Hz tick
SAMPLES = 0.05      # [s] a 20 Hz link: the designs differ between its samples
DELAY = 0.2         # [s]
SWITCH = 200        # the tick the settings are set on


def _offset(t: float) -> list[float]:
    return [0.02 * math.sin(2.0 * math.pi * 0.7 * t), 0.01 * math.cos(2.0 * math.pi * 0.7 * t), 0.0]


def _run(start: bool, switch_to: bool | None, ticks: int = 900) -> np.ndarray:
    pose = DesiredPose(DesiredPoseParameters(interpolate_link_samples=start))
    pose.start(np.zeros(3), np.eye(3))
    positions = []
    for k in range(ticks):
        now = k * PERIOD
        if k % round(SAMPLES / PERIOD) == 0:
            pose.add_teleoperation(round(now * 1e9), _offset(now), now + DELAY)
        if k == SWITCH and switch_to is not None:
            pose.parameters = DesiredPoseParameters(interpolate_link_samples=switch_to)
        positions.append(pose.update(now + DELAY, PERIOD).position.copy())
    return np.array(positions)


def test_the_same_design_set_again_changes_nothing() -> None:
    for design in (True, False):
        np.testing.assert_array_equal(_run(design, design), _run(design, None))


def test_a_new_design_is_followed_as_by_a_pose_started_with_it() -> None:
    interpolated, extrapolated = _run(True, None), _run(False, None)
    assert np.abs(interpolated[SWITCH:] - extrapolated[SWITCH:]).max() > 1e-4     # the designs differ
    for start, switch_to, reference in ((True, False, extrapolated), (False, True, interpolated)):
        switched = _run(start, switch_to)
        np.testing.assert_allclose(switched[-100:], reference[-100:], rtol=0.0, atol=1e-12)
