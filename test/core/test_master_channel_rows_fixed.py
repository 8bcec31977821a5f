"""The channel's master port is built once, at start, from its rows (docs/ARCHITECTURE.md: the channel port's rows
are read-only in the table, so rclpy refuses a live change before the station sees it): every row of the master's
table that sets the port, the damper's bound with the switch and the window, is declared read-only, and the
station refuses a live change of each by name, keeping the port it has."""
from __future__ import annotations

import pytest
from config_values import config_values

from fic_core.channel_ports import CHANNEL_PORT_NUMBERS, CHANNEL_PORT_SWITCHES
from fic_core.errors import FicInputError
from fic_core.master_station import MASTER_PARAMETERS, READ_ONLY, MasterParameters, MasterStation

DEFAULTS = config_values("master.yaml")


def test_every_row_of_the_channels_master_port_is_fixed_at_start() -> None:
    port_rows = {name for name in MASTER_PARAMETERS if name.startswith("channel_")}
    assert {"channel_max_damping"} | set(CHANNEL_PORT_NUMBERS) | set(CHANNEL_PORT_SWITCHES) <= port_rows
    for name in sorted(port_rows):
        assert MASTER_PARAMETERS[name].read_only, name
        assert name in READ_ONLY, name
    station = MasterStation(MasterParameters.from_values(DEFAULTS))
    port = station.channel_port
    for name in sorted(port_rows):
        with pytest.raises(FicInputError, match=f"^{name} is fixed at start$"):
            station.configure({name: DEFAULTS[name]})
    assert station.channel_port is port
