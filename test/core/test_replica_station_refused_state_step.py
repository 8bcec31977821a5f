"""A joint state the replica refuses drives no control tick: its step carries no report, no law torque and nothing
due to publish (no desired/TCP poses, no F_R, no status), while its command repeats the last one sent. Before any
state was used there is nothing to repeat, and still nothing is due."""
from __future__ import annotations

import numpy as np
from config_values import config_values

from fic_core.panda_description import ARM_JOINT_NAMES, NOMINAL_CONFIGURATION
from fic_core.replica_station import ReplicaParameters, ReplicaStation

Q0 = np.array(NOMINAL_CONFIGURATION, dtype=float)
QD0 = np.zeros(7)


def _nothing_due(step) -> bool:
    return (step.command is None and step.torque is None and not step.poses_due and not step.status_due
            and not step.held and step.notices == [])


def test_a_refused_state_is_no_tick_and_makes_nothing_due() -> None:
    values = {**config_values("replica.yaml"), "control_rate": 500.0, "command_period": 0.002,
              "exchanged_energy_observer": False}
    replica = ReplicaStation(ReplicaParameters.from_values(values))
    first, error = replica.named_joint_state(0.002, 0.002, ["a"], [0.0], [0.0], 2_000_000)
    assert error is not None and first.command is None and _nothing_due(first.step)
    used, error = replica.named_joint_state(0.004, 0.004, list(ARM_JOINT_NAMES), Q0.tolist(), QD0.tolist(),
                                            4_000_000)
    assert error is None and used.step.command is not None
    refused, error = replica.named_joint_state(0.006, 0.006, ["a", "b"], [0.0, 0.0], [0.0, 0.0], 6_000_000)
    assert error is not None and _nothing_due(refused.step)
    np.testing.assert_array_equal(refused.command, used.command)
