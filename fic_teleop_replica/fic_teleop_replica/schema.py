"""The replica node's parameters, one table (fic_teleop_runtime.parameters): the control loop's rows from
fic_core.replica_parameters (which checks the same ranges in-process), the driver's (driver_interface) and the
input authority's (input_guard) and the channel port's. Their values are config/replica.yaml's."""
from __future__ import annotations

from fic_core.channel_ports import CHANNEL_PORT_NUMBERS, CHANNEL_PORT_SWITCHES
from fic_core.exchanged_energy_ports import EXCHANGED_ENERGY_SWITCHES
from fic_core.replica_parameters import CONTROLLER_DESCRIPTION, REPLICA_NUMBERS, REPLICA_SWITCHES
from fic_teleop_replica.driver_interface import DRIVER_PARAMETERS
from fic_teleop_replica.input_guard import AUTHORITY_PARAMETERS
from fic_teleop_runtime.parameters import Schema, text

LOOP_PARAMETERS = (text("controller", CONTROLLER_DESCRIPTION), *REPLICA_NUMBERS.values(), *REPLICA_SWITCHES.values())
#: The channel's replica port (fic_core.channel_ports) and the FIC port's exchanged-energy observer, fixed at start.
CHANNEL_PORT_PARAMETERS = (*CHANNEL_PORT_SWITCHES.values(), *CHANNEL_PORT_NUMBERS.values(),
                           *EXCHANGED_ENERGY_SWITCHES.values())
SCHEMA = Schema("replica.yaml", LOOP_PARAMETERS, DRIVER_PARAMETERS, AUTHORITY_PARAMETERS, CHANNEL_PORT_PARAMETERS)
