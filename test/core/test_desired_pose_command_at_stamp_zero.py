"""A teleoperation command is unused until a control tick uses it, whatever its stamp: one stamped exactly 0 ns (a
simulated clock's first stamps can be 0, before its first /clock) and one at 1 ns are each unused when they
arrive, used by the next tick, which records the command's stamp and its age at that first use, once."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.desired_pose import DesiredPose, DesiredPoseParameters

START = np.array([0.3, 0.0, 0.5])


@pytest.mark.parametrize("stamp_ns", [0, 1])
def test_a_command_at_the_clocks_start_is_unused_until_a_tick_uses_it(stamp_ns: int) -> None:
    pose = DesiredPose(DesiredPoseParameters())
    pose.start(START, np.eye(3))
    assert not pose.command_unused                 # no command yet
    pose.add_teleoperation(stamp_ns, [0.0, 0.0, 0.0], 0.01)
    assert pose.command_unused
    pose.update(0.02, 0.001)
    assert not pose.command_unused and pose.master_stamp_used_ns == stamp_ns
    assert pose.master_first_use_age == pytest.approx(0.02 - stamp_ns * 1e-9)
    pose.update(0.03, 0.001)
    assert pose.master_first_use_age == pytest.approx(0.02 - stamp_ns * 1e-9)
