"""The master watchdog's line in the replica's /diagnostics: "no command yet" until a first teleoperation command
is taken in, then "ok"; never "ok" before any command (a replica holding its start pose is not being driven)."""
from __future__ import annotations

from config_values import replica_loop_parameters

from fic_core.replica_loop import ReplicaLoop


def test_no_command_yet_then_ok() -> None:
    loop = ReplicaLoop(replica_loop_parameters())
    assert loop.watchdog_state() == "no command yet"
    assert loop.statistics()["master_watchdog"] == "no command yet"
    loop.add_teleoperation(1_000_000, [0.0, 0.0, 0.0], 0.001)
    assert loop.watchdog_state() == "ok"
