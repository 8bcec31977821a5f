"""Every joint state the replica receives is counted once in ``joint_states`` (the count /diagnostics reports
against the robot's rate), whether it drove a control tick, was skipped unread between ticks (realtime at a law
rate below the state rate) or was refused; refusals are counted again on their own."""
from __future__ import annotations

import numpy as np
from config_values import replica_loop_parameters

from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.replica_loop import ReplicaLoop

Q0, QD0 = np.array(NOMINAL_CONFIGURATION, dtype=float), np.zeros(7)


def test_used_skipped_and_refused_states_are_each_counted_once() -> None:
    loop = ReplicaLoop(replica_loop_parameters(control_rate=250.0))
    used = skipped = 0
    for k in range(40):   # 1 kHz states, a 250 Hz law: one state in four drives a tick
        time = k * 0.001
        if loop.skips(time):
            loop.skip()
            skipped += 1
        else:
            loop.joint_state(time, time, Q0, QD0)
            used += 1
    assert (used, skipped) == (10, 30)
    assert loop.counts["control_ticks"] == 10
    assert loop.counts["joint_states"] == 40
    loop.refuse_joint_state()
    loop.refuse_joint_state()
    assert loop.counts["joint_states"] == 42 and loop.counts["rejected_joint_states"] == 2
