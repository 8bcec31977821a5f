"""One evidence cell (E1 at 0.2 s one-way delay, the FIC) with two seeds on the in-process runner: the small version
of fic_teleop_experiments.evidence_sweep that the suite runs. 16.5 s a run is about the shortest the verdict
assesses at this delay: its motion test removes E1's 5 s lap with the lap's median over 2 laps after 1 s of
settling, one lap and one 0.4 s round trip (energy_verdict.EnergyMotionCriterion.lap_start)."""
from __future__ import annotations

import numpy as np

from fic_teleop_experiments.cell_statistics import cell_statistics
from fic_teleop_experiments.evidence_run import judge

CELL = dict(id="delay_0.2", options=dict(delay=0.2))


def test_one_cell_two_seeds():
    rows = [judge((CELL, "fic", seed, 16.5)) for seed in (1, 2)]
    for row in rows:
        assert row["assessed"], row["reasons"]
        # The paper's setting (200 ms): the FIC is stable, tracks within a few x_b and stays inside the limits.
        assert row["stable"], row["reasons"]
        assert row["laps_in_lap_median"] >= 2.0
        assert row["error_max_m"] < 0.2
        assert row["limit_violations"] == 0
        assert np.isfinite(row["peak_force_n"])
    # The seeds draw different operators (timing, hand impedance), not the same run twice.
    assert rows[0]["operator_time_shift_s"] != rows[1]["operator_time_shift_s"]
    assert rows[0]["error_rms_m"] != rows[1]["error_rms_m"]
    stats = cell_statistics([r["stable"] for r in rows], [r["error_rms_m"] for r in rows],
                            [r["error_max_m"] for r in rows], [r["peak_force_n"] for r in rows])
    assert (stats.stable, stats.assessed) == (2, 2)
    assert stats.stable_interval_95[0] > 0.15
