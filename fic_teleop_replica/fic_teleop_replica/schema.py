"""The replica node's parameters, one table (fic_teleop_runtime.parameters): the control loop's rows from
fic_core.replica_parameters (which checks the same ranges in-process), the driver's (driver_interface) and the
input authority's (input_guard). Their values are config/replica.yaml's."""
from __future__ import annotations

from fic_core.replica_parameters import CONTROLLER_DESCRIPTION, REPLICA_NUMBERS, REPLICA_SWITCHES
from fic_teleop_replica.driver_interface import DRIVER_PARAMETERS
from fic_teleop_replica.input_guard import AUTHORITY_PARAMETERS
from fic_teleop_runtime.parameters import Schema, number, switch, text

LOOP_PARAMETERS = (
    text("controller", CONTROLLER_DESCRIPTION),
    *(number(name, low, high, description) for name, (description, low, high) in REPLICA_NUMBERS.items()),
    *(switch(name, description) for name, description in REPLICA_SWITCHES.items()),
)
SCHEMA = Schema("replica.yaml", LOOP_PARAMETERS, DRIVER_PARAMETERS, AUTHORITY_PARAMETERS)
