"""The replica node's parameters, one table (fic_teleop_runtime.parameters): the control loop's rows from
fic_core.replica_parameters (which checks the same ranges in-process), the driver's (driver_interface) and the
input authority's (input_guard) and the channel port's. Their values are config/replica.yaml's."""
from __future__ import annotations

from fic_core.channel_ports import CHANNEL_PORT_NUMBERS, CHANNEL_PORT_SWITCHES
from fic_core.exchanged_energy_ports import EXCHANGED_ENERGY_SWITCHES
from fic_core.replica_parameters import CONTROLLER_DESCRIPTION, REPLICA_NUMBERS, REPLICA_SWITCHES
from fic_teleop_replica.driver_interface import DRIVER_PARAMETERS
from fic_teleop_replica.input_guard import AUTHORITY_PARAMETERS
from fic_teleop_runtime.parameters import Schema, number, switch, text

LOOP_PARAMETERS = (
    text("controller", CONTROLLER_DESCRIPTION),
    *(number(name, low, high, description) for name, (description, low, high) in REPLICA_NUMBERS.items()),
    *(switch(name, description) for name, description in REPLICA_SWITCHES.items()),
)
#: The channel's replica port (fic_core.channel_ports) and the FIC port's exchanged-energy observer, fixed at start.
CHANNEL_PORT_PARAMETERS = (
    *(switch(name, description, read_only=True) for name, description in CHANNEL_PORT_SWITCHES.items()),
    *(number(name, low, high, description, read_only=True)
      for name, (low, high, description) in CHANNEL_PORT_NUMBERS.items()),
    *(switch(name, description, read_only=True) for name, description in EXCHANGED_ENERGY_SWITCHES.items()),
)
SCHEMA = Schema("replica.yaml", LOOP_PARAMETERS, DRIVER_PARAMETERS, AUTHORITY_PARAMETERS, CHANNEL_PORT_PARAMETERS)
