"""The /diagnostics statuses of the passivity watches both stations run: the channel's port (fic_core.channel_ports)
and the FIC port's exchanged energy (fic_core.exchanged_energy_ports). One spelling for the master and the replica,
so that a monitor reads both sides alike (docs/INTERFACES.md)."""
from __future__ import annotations

from collections.abc import Mapping

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from fic_core.exchanged_energy_observer import ExchangedEnergyObserver


def channel_port_status(station: str, link: str, port: Mapping[str, float]) -> DiagnosticStatus:
    """``<station>: channel port``: WARN once the ``link`` (forward, backward) got energy out at this port that the
    other side never put in (a negative observer tick)."""
    return DiagnosticStatus(
        name=f"{station}: channel port", hardware_id=f"fic_teleop_{station}",
        level=DiagnosticStatus.WARN if port["negative_ticks"] > 0 else DiagnosticStatus.OK,
        message=f"{link} link generated {port['generated_j']:.4f} J, {port['generated_rate_w']:.4f} W",
        values=[KeyValue(key=key, value=f"{value:.9g}") for key, value in port.items()])


def exchanged_energy_status(station: str, observer: ExchangedEnergyObserver, damping_unit: str) -> DiagnosticStatus:
    """``<station>: exchanged energy``: WARN once energy came out that neither the storage nor the sampling accounts
    for (a violation tick)."""
    return DiagnosticStatus(
        name=f"{station}: exchanged energy", hardware_id=f"fic_teleop_{station}",
        level=DiagnosticStatus.WARN if observer.violation_ticks else DiagnosticStatus.OK,
        message=f"shortfall {observer.shortfall_j:.4g} J, damping needed {observer.damping_needed:.3g} "
                f"{damping_unit}",
        values=[KeyValue(key=key, value=value) for key, value in observer.diagnostics().items()])
