"""The channel's ports in the running graph (fic_core.channel_ports in the master and the replica node): one short
lockstep run of ``--controller linear_tdpa`` at 1 s each way over DDS, and the same seconds in one process.

The graph run must show both ports' observers on /diagnostics (in the bag, so in metrics.json) with TDPA on, run
the replica's linear_bounded law, and agree with the in-process runner on what the law and the channel produce:
the tracking error's RMS and the channel's energy balance (E_out - E_in at both ports, with the passivity
controllers acting). The run lasts until the operator's moves, timed for the delay, have reached the obstacles
(first contact at 5.1 s in the runner), so the channel carries energy: without TDPA it generates 34 mJ by 8 s,
with it 0.3 mJ. Tolerances and the measured figures: docs/RESULTS.md, "Passivity in the graph".
"""
from __future__ import annotations

import json

import pytest
from conftest import run_launcher

pytestmark = pytest.mark.nodes
DURATION_S, DELAY_S = 8.0, 1.0
ERROR_RMS_TOLERANCE_M = 0.006       # | RMS |e|_graph - RMS |e|_in-process | (measured 0.2-2.4 mm)
# | balance_graph - balance_in-process | against what the channel generates in process without TDPA (34 mJ): the
# graph's TDPA must take away at least half of it. Measured differences: 4.1-6.4 mJ (2026-12-04), 1.0, 1.5, 10.5 and
# 15.3 mJ (2026-12-05: the channel nodes are not lockstep peers, so the graph's deliveries vary from run to run).
ENERGY_SHARE_LEFT = 0.5
GENERATED_WITHOUT_TDPA_MIN_J = 0.02   # the cell must make the delayed channel generate energy (34 mJ measured)


def test_linear_tdpa_runs_in_the_graph_with_both_ports_watched(tmp_path) -> None:
    from fic_teleop_experiments.graph_passivity import compare
    from fic_teleop_experiments.in_process import RunConfig

    out = tmp_path / "run"
    process = run_launcher(out, "--duration", str(DURATION_S), "--delay", str(DELAY_S), "--time-mode", "lockstep",
                           "--controller", "linear_tdpa", "--no-video", "--wall-limit", "500")
    assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
    metrics = json.loads((out / "report" / "metrics.json").read_text())
    assert metrics["controller"] == "linear_bounded"
    ports = metrics["channel_ports"]
    assert ports is not None, "no channel port status on /diagnostics"
    for side in ("master", "replica"):
        assert ports[side]["passivity_control"] == 1.0
        assert ports[side]["input_energy_j"] > 0.0 and ports[side]["output_energy_j"] > 0.0   # energy flowed
    assert ports["master"]["ticks"] >= 0.5 * (DURATION_S - 1.0) * 250      # master control ticks booked
    assert metrics["channel_forward_generated_j"] == ports["replica"]["generated_j"]
    assert metrics["channel_backward_generated_j"] == ports["master"]["generated_j"]
    # The handle's FIC under the exchanged-energy observer (the replica's linear law has no FIC storage to judge).
    assert metrics["exchanged_energy"]["master"]["ticks"] > 0 and metrics["exchanged_energy"]["replica"]["ticks"] == 0

    compared = compare(out, RunConfig(duration=DURATION_S, delay=DELAY_S, controller="linear_tdpa"))
    print(f"[probe] error RMS graph {compared.graph_error_rms_m * 1e3:.1f} / in process "
          f"{compared.in_process_error_rms_m * 1e3:.1f} mm; balance graph {compared.graph_balance_j * 1e3:.1f} / in "
          f"process {compared.in_process_balance_j * 1e3:.1f} mJ; replica holds "
          f"{metrics.get('loop_health', {}).get('holds', 'n/a')}")
    assert abs(compared.graph_error_rms_m - compared.in_process_error_rms_m) <= ERROR_RMS_TOLERANCE_M, compared
    # the delay does generate energy
    assert compared.in_process_without_tdpa_j > GENERATED_WITHOUT_TDPA_MIN_J, compared
    assert abs(compared.graph_balance_j - compared.in_process_balance_j) <= (
        ENERGY_SHARE_LEFT * compared.in_process_without_tdpa_j), compared
