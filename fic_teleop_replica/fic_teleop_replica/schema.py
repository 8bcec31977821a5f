"""The replica node's parameters, one table (fic_teleop_runtime.parameters): fic_core.replica_station's
REPLICA_PARAMETERS, the rows of the control loop (fic_core.replica_parameters, which checks the same ranges
in-process), the driver (fic_core.replica_driver), the input authority (fic_core.input_authority) and the channel's
replica port; and the node's own ROBOT_IN_PROCESS. Their values are config/replica.yaml's; the station takes its own
as one ReplicaParameters."""
from __future__ import annotations

from fic_core.replica_station import REPLICA_PARAMETERS
from fic_teleop_runtime.parameters import Schema, switch

#: The node's own row, not the station's: where its joint states come from (fic_teleop_runtime.in_process_link).
ROBOT_IN_PROCESS = switch("robot_in_process", "the simulated robot runs in this process (a node group with "
                                              "controller_in_process): its physics thread calls the control step, "
                                              "no DDS between them")

SCHEMA = Schema("replica.yaml", REPLICA_PARAMETERS.values(), ROBOT_IN_PROCESS)
