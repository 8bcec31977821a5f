"""The replica node's parameters, one table (fic_teleop_runtime.parameters): fic_core.replica_station's
REPLICA_PARAMETERS, the rows of the control loop (fic_core.replica_parameters, which checks the same ranges
in-process), the driver (fic_core.replica_driver), the input authority (fic_core.input_authority) and the channel's
replica port. Their values are config/replica.yaml's; the station takes them as one ReplicaParameters."""
from __future__ import annotations

from fic_core.replica_station import REPLICA_PARAMETERS
from fic_teleop_runtime.parameters import Schema

SCHEMA = Schema("replica.yaml", REPLICA_PARAMETERS.values())
