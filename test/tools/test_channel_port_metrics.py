"""metrics.json's live passivity figures from the bag's /diagnostics (fic_teleop_tools.report.metrics): the channel
ports' balance and per-direction figures, and the FIC ports' exchanged energy, from each status's last key-values."""
from __future__ import annotations

from pathlib import Path

import pytest

from fic_teleop_tools.report.bag_data import BagData
from fic_teleop_tools.report.metrics import channel_port_metrics, exchanged_energy_metrics


def bag(diagnostics: dict[str, dict[str, str]]) -> BagData:
    return BagData(path=Path("bag.mcap"), complete=True, stopped_by="", counts={}, types={}, series={},
                   controller="", deliveries={}, first_log=0.0, last_log=0.0, diagnostics=diagnostics)


def port(input_j: float, output_j: float, received_j: float, negative: int) -> dict[str, str]:
    return {"input_energy_j": str(input_j), "output_energy_j": str(output_j),
            "received_input_energy_j": str(received_j), "generated_j": str(output_j - received_j),
            "negative_ticks": str(negative), "passivity_control": "1"}


def test_the_channel_balance_is_both_ports_out_minus_both_in() -> None:
    figures = channel_port_metrics(bag({"master: channel port": port(0.5, 0.25, 0.125, 3),
                                        "replica: channel port": port(0.125, 0.75, 0.5, 4)}))
    assert figures["channel_observed_generated_j"] == pytest.approx(0.25 + 0.75 - 0.5 - 0.125)
    assert figures["channel_backward_generated_j"] == pytest.approx(0.125)   # at the master: the F_R link
    assert figures["channel_forward_generated_j"] == pytest.approx(0.25)     # at the replica: the x_d' link
    assert figures["channel_port_negative_ticks"] == 7
    assert figures["channel_ports"]["master"]["passivity_control"] == 1.0


def test_without_the_statuses_the_figures_are_null() -> None:
    assert all(value is None for value in channel_port_metrics(bag({"replica: channel port": port(0, 0, 0, 0)}))
               .values())
    assert exchanged_energy_metrics(bag({})) == {"exchanged_energy": {"replica": None, "master": None},
                                                 "exchanged_energy_violation_ticks": None}


def test_exchanged_energy_per_side() -> None:
    figures = exchanged_energy_metrics(bag({"master: exchanged energy": {"shortfall_j": "0.0065",
                                                                        "violation_ticks": "2", "ticks": "1106"}}))
    assert figures["exchanged_energy"]["replica"] is None
    assert figures["exchanged_energy"]["master"]["shortfall_j"] == pytest.approx(0.0065)
    assert figures["exchanged_energy_violation_ticks"] == 2
