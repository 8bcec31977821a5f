"""Parameter objects built without arguments are the shipped ones (config/replica.yaml and config/master.yaml are
the one home of the defaults): the desired pose's parameters and the replica loop's health bounds, field by field
against the replica's file; and the master's rates and frame, from which its node creates timers and messages at
start, are fixed at start (a live change is refused)."""
from __future__ import annotations

import dataclasses

import pytest
from config_values import config_values

from fic_core.desired_pose import DesiredPoseParameters
from fic_core.errors import FicInputError
from fic_core.loop_health import LoopHealthBounds
from fic_core.master_station import MASTER_PARAMETERS, READ_ONLY, MasterParameters, MasterStation

REPLICA = config_values("replica.yaml")


def test_the_desired_poses_defaults_are_the_replicas_shipped_values() -> None:
    fields = [field.name for field in dataclasses.fields(DesiredPoseParameters)]
    assert len(fields) >= 11 and set(fields) <= set(REPLICA)
    defaults = DesiredPoseParameters()
    for name in fields:
        assert getattr(defaults, name) == REPLICA[name], name


def test_the_loop_health_defaults_are_the_replicas_shipped_loop_bounds() -> None:
    defaults = LoopHealthBounds()
    for field in dataclasses.fields(LoopHealthBounds):
        assert getattr(defaults, field.name) == REPLICA["loop_" + field.name], field.name


def test_the_masters_rates_and_frame_are_fixed_at_start() -> None:
    fixed = {name for name in MASTER_PARAMETERS if name.endswith("_rate")} | {"frame_id"}
    assert fixed == {"control_rate", "network_rate", "diagnostics_rate", "tools_rate", "frame_id"}
    assert fixed <= set(READ_ONLY)
    station = MasterStation(MasterParameters.from_values(config_values("master.yaml")))
    for name in sorted(fixed - {"frame_id"}):
        with pytest.raises(FicInputError, match=f"{name} is fixed at start"):
            station.configure({name: 50.0})
