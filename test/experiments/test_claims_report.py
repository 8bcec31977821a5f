"""The claim sweep's statistics from its judged runs: counts, the comparisons, dedup of resumed runs, unjudged runs,
both row layouts, the tables and the figures."""
from __future__ import annotations

import json

import pytest

from fic_teleop_experiments.cell_statistics import boschloo_p, fisher_p, newcombe_difference_interval, wilson_interval
from fic_teleop_experiments.claims_report import claims_statistics, main, read_runs


def _row(cell: str, law: str, seed: int, stable, safe=True, hand="passive", **extra) -> dict:
    """A row as the claim sweep's --judge writes it (verdict and figures nested)."""
    return dict(key=f"{cell}__{law}__{hand}__{seed}", cell=cell, delay=1.0, rate_hz=10.0, controller=law, hand=hand,
                seed=seed, figures=dict(error_rms_m=0.001 * seed, error_max_m=0.01 * seed, peak_force_n=float(seed)),
                verdict=dict(stable=stable, safe=safe, stable_reasons=[], safe_reasons=[]), **extra)


def _runs() -> list[dict]:
    rows = [_row("delay_1__rate_10", "fic", seed, True) for seed in range(1, 21)]
    rows += [_row("delay_1__rate_10", "linear", seed, seed <= 12, safe=seed != 3) for seed in range(1, 21)]
    rows += [_row("delay_1__rate_10", "linear_tdpa", seed, None if seed == 1 else True) for seed in range(1, 6)]
    return rows


def test_counts_and_comparisons_match_the_statistics():
    document = claims_statistics(_runs(), seeds_planned=20)
    (cell,) = document["cells"]
    assert (cell["cell"], cell["hand"], cell["delay"], cell["rate_hz"]) == ("delay_1__rate_10", "passive", 1.0, 10.0)
    fic, linear, tdpa = cell["laws"]["fic"], cell["laws"]["linear"], cell["laws"]["linear_tdpa"]
    assert (fic["stable"]["k"], fic["stable"]["n"]) == (20, 20)
    assert (linear["stable"]["k"], linear["stable"]["n"], linear["safe"]["k"]) == (12, 20, 19)
    assert linear["stable"]["interval_95"] == pytest.approx(wilson_interval(12, 20))
    assert (tdpa["stable"]["k"], tdpa["stable"]["n"], tdpa["runs"]) == (4, 4, 5)   # seed 1 too short to judge
    assert linear["seeds"] == list(range(1, 21))
    assert linear["error_rms_median"] == pytest.approx(0.0105)
    assert linear["peak_force_p95"] == pytest.approx(19.05)
    comparison = next(c for c in document["comparisons"] if c["baseline"] == "linear")
    assert comparison["hand"] == "passive"
    stable = comparison["stable"]
    assert stable["difference"] == pytest.approx(0.4)
    assert stable["difference_interval_95"] == pytest.approx(newcombe_difference_interval(20, 20, 12, 20)[1:])
    assert stable["boschloo_p"] == pytest.approx(boschloo_p(20, 20, 12, 20))
    assert stable["fisher_p"] == pytest.approx(fisher_p(20, 20, 12, 20))
    assert {c["baseline"] for c in document["comparisons"]} == {"linear", "linear_tdpa"}
    assert (document["runs_total"], document["runs_judged"], document["runs_judged_stable"]) == (45, 45, 44)


def test_hands_split_cells_flat_rows_count_and_a_cell_without_the_fic_has_no_comparison():
    flat = dict(cell="d", controller="linear", seed=1, stable=True, safe=True, error_rms_m=0.01, error_max_m=0.02,
                peak_force_n=3.0)
    rows = [_row("c", "fic", 1, True), _row("c", "fic", 1, False, hand="reactive"), flat]
    document = claims_statistics(rows)
    assert sorted((c["cell"], c.get("hand")) for c in document["cells"]) == [("c", "passive"), ("c", "reactive"),
                                                                           ("d", None)]
    (d,) = [c for c in document["cells"] if c["cell"] == "d"]
    assert (d["laws"]["linear"]["stable"]["k"], d["laws"]["linear"]["peak_force_median"]) == (1, 3.0)
    assert document["comparisons"] == []


def test_run_file_keeps_the_last_row_of_a_run_skips_torn_lines_and_counts_unjudged_runs(tmp_path):
    path = tmp_path / "claims_runs.jsonl"
    unjudged = _row("c", "linear", 1, True)
    del unjudged["verdict"]
    lines = [json.dumps(_row("c", "fic", 1, False)), json.dumps(_row("c", "fic", 1, True)), json.dumps(unjudged),
             '{"cell": "c", "con']
    path.write_text("\n".join(lines) + "\n")
    runs = read_runs(path)
    assert len(runs) == 2
    document = claims_statistics(runs)
    laws = document["cells"][0]["laws"]
    assert (laws["fic"]["stable"]["k"], laws["fic"]["stable"]["n"]) == (1, 1)
    assert (laws["linear"]["runs"], laws["linear"]["judged"], laws["linear"]["stable"]["n"]) == (1, 0, 0)
    assert document["comparisons"][0]["stable"]["difference"] is None


def test_command_line_writes_the_statistics_tables_and_figures(tmp_path):
    path = tmp_path / "claims.json"
    path.write_text(json.dumps({"runs": _runs(), "commit": "abc"}))
    assert main([str(path), "--seeds-planned", "20"]) == 0
    document = json.loads((tmp_path / "claims_statistics.json").read_text())
    assert document["seeds_planned"] == 20 and document["runs_judged"] == 45 and document["source"] == "claims.json"
    tables = (tmp_path / "claims_tables.md").read_text()
    assert "| delay_1__rate_10 passive | linear | 20 | 12/20 | 0.39-0.78 | - | " in tables
    assert "| delay_1__rate_10 passive | linear | stable | 20/20 | 12/20 | +0.40 | +0.16 to +0.61 |" in tables
    for name in ("claims_proportions.png", "claims_differences.png"):
        assert (tmp_path / name).stat().st_size > 10_000
    with pytest.raises(SystemExit):
        main([str(tmp_path / "missing.json")])


def test_claim_reading_thresholds():
    from fic_teleop_experiments.tables import claim_reading
    assert claim_reading({"k": 20, "n": 20, "interval_95": wilson_interval(20, 20)}) == "reproduced"
    assert claim_reading({"k": 19, "n": 20, "interval_95": wilson_interval(19, 20)}) == "reproduced"
    assert claim_reading({"k": 18, "n": 20, "interval_95": wilson_interval(18, 20)}) == "undecided at n = 20"
    assert claim_reading({"k": 8, "n": 8, "interval_95": wilson_interval(8, 8)}) == "undecided at n = 8"
    assert claim_reading({"k": 11, "n": 20, "interval_95": wilson_interval(11, 20)}) == "not reproduced"
    assert claim_reading({"k": 0, "n": 0, "interval_95": None}) == "no run judged yet"


def test_claims_block_reads_the_statistics_and_says_when_a_cell_has_no_runs(tmp_path, capsys):
    rows = [_row("delay_1__rate_10", "fic", seed, True) for seed in range(1, 9)]
    rows += [_row("delay_1__rate_10", "linear", seed, seed != 2) for seed in range(1, 9)]
    path = tmp_path / "claims_statistics.json"
    path.write_text(json.dumps(claims_statistics(rows, seeds_planned=20)))
    assert main(["--block", str(path)]) == 0
    block = capsys.readouterr().out
    assert "Judged so far: 16 runs of the claim sweep (8-8 judged seeds a law, cell and hand, of 20 planned)" in block
    assert ("| 1 s one-way delay and the link at 10 Hz both ways, together (`delay_1__rate_10`) | passive | "
            "8/8 (0.68-1.00) | 8/8 (0.68-1.00) | linear 7/8 | linear +0.12 (-0.22 to +0.47; p ") in block
    assert block.count("no run judged yet") == 2 and "undecided at n = 8" in block
    assert block.endswith("Of these 3 claim rows: 0 reproduced, 0 not reproduced, 1 undecided at the seeds judged so "
                          "far, 2 without a judged run yet.\n")


def test_claims_block_of_a_finished_sweep_says_all_runs_judged(tmp_path, capsys):
    """Every claim cell, law and hand at its planned seeds: the block says so, not "so far"."""
    from fic_teleop_experiments.tables import RESULTS_CLAIM_CELLS
    rows = [_row(cell, law, seed, True, hand=hand) for cell, _ in RESULTS_CLAIM_CELLS for law in ("fic", "linear")
            for hand in ("passive", "reactive") for seed in (1, 2)]
    path = tmp_path / "claims_statistics.json"
    path.write_text(json.dumps(claims_statistics(rows, seeds_planned=2)))
    assert main(["--block", str(path)]) == 0
    block = capsys.readouterr().out
    assert block.startswith(f"All {len(rows)} runs of the claim sweep judged (2 seeds a law, cell and hand). ")
    assert "so far" not in block and "resumes" not in block
    assert "undecided at 2 seeds.\n" in block


def test_claims_block_with_its_claim_rows_complete_and_other_cells_running_says_so(tmp_path, capsys):
    """The sweep runs the claim cells first: once they are at their planned seeds the claim rows are final, while a
    cell outside the block (2 s here) still has fewer runs; the block says which is which."""
    from fic_teleop_experiments.tables import RESULTS_CLAIM_CELLS
    rows = [_row(cell, law, seed, seed != 1 or law == "linear", hand=hand) for cell, _ in RESULTS_CLAIM_CELLS
            for law in ("fic", "linear") for hand in ("passive", "reactive") for seed in (1, 2)]
    rows += [_row("delay_2__rate_10", "fic", 1, True)]
    path = tmp_path / "claims_statistics.json"
    path.write_text(json.dumps(claims_statistics(rows, seeds_planned=2)))
    assert main(["--block", str(path)]) == 0
    block = capsys.readouterr().out
    assert block.startswith(f"The claim rows are complete (2 seeds or more a law, cell and hand); {len(rows)} runs of "
                            "the claim sweep judged so far, its other cells (the open-loop controls, 2 s and the delay "
                            "sweep's extra delays) still running. ")
    assert block.count("| 1/2 (") == 6   # the FIC's share in each claim row: seed 1 unstable
    assert "0 reproduced, 0 not reproduced, 6 undecided at the seeds of each row.\n" in block


def test_tables_say_how_many_runs_were_too_short_to_judge():
    from fic_teleop_experiments.tables import claims_markdown
    rows = [_row("c", "fic", 1, None), _row("c", "fic", 2, True)]
    table = claims_markdown(claims_statistics(rows))
    assert "| c passive | fic | 2 | 1/1 (1 not assessed) | 0.21-1.00 | - | " in table


def test_update_results_replaces_only_the_block(tmp_path):
    from fic_teleop_experiments.tables import claims_block
    path = tmp_path / "claims.json"
    path.write_text(json.dumps({"runs": _runs()}))
    results = tmp_path / "RESULTS.md"
    results.write_text("# x\n\nbefore\n<!-- claims: begin (generated) -->\nold 1/2\n<!-- claims: end -->\nafter\n")
    assert main([str(path), "--update-results", str(results)]) == 0
    statistics = json.loads((tmp_path / "claims_statistics.json").read_text())
    assert results.read_text() == ("# x\n\nbefore\n<!-- claims: begin (generated) -->\n" + claims_block(statistics)
                                  + "<!-- claims: end -->\nafter\n")
    results.write_text("no block\n")
    with pytest.raises(SystemExit):
        main([str(path), "--update-results", str(results)])


def test_each_stable_test_is_counted_where_it_failed():
    """The table that tells which test decided a law's share: one count per test, a run failing two counts twice."""
    rows = _runs()
    reasons = {1: ["sustained oscillation of x_d - x_R: 9.0 mm at 1.60 s"],
               4: ["free oscillation in the quiet tail: x_R - command swings 4.0 mm in its last window"],
               5: ["free oscillation in the quiet tail: x_M - operator target swings 2.0 mm in its last window",
                   "energy does not decay in the quiet tail: kinetic energy peaks at 3 mJ in its last window"],
               2: ["steady energy generation at the channel's ports: 80 mW", "runaway: joint 2 at 3.00 rad/s"],
               3: ["parked: |x_d - x_R| above 100 mm for 4.0 s on end outside contact"]}
    for row in rows:
        if row["controller"] == "linear" and row["seed"] in reasons:
            row["verdict"].update(stable=False, stable_reasons=reasons[row["seed"]])
    (cell,) = claims_statistics(rows, seeds_planned=20)["cells"]
    assert cell["laws"]["linear"]["unstable_by_test"] == {"tail motion": 2, "tail energy": 1,
                                                          "oscillation (no tail)": 1, "growing energy": 0,
                                                          "port generation": 1, "runaway": 1, "parked": 1}
    assert set(cell["laws"]["fic"]["unstable_by_test"].values()) == {0}


def test_an_open_loop_control_is_shown_beside_its_claim_cell_and_left_out_of_the_tally():
    from fic_teleop_experiments.tables import claims_block

    rows = [_row("delay_1__rate_10", "fic", seed, seed <= 9, hand="reactive") for seed in range(1, 21)]
    rows += [_row("delay_1__rate_10__feedback_off", "fic", seed, seed <= 11, hand="reactive") for seed in range(1, 21)]
    rows += [_row("delay_1__rate_10__feedback_off", "linear", seed, seed <= 15, hand="reactive")
             for seed in range(1, 21)]
    block = claims_block(claims_statistics(rows, seeds_planned=20))
    assert ("| control: 1 s and 10 Hz, the force feedback off (no force loop through the channel) "
            "(`delay_1__rate_10__feedback_off`) | reactive | 11/20 ") in block
    assert "| control, not a claim |" in block
    # The tally counts the 3 claim rows only (the control is not a claim).
    assert ("Of these 3 claim rows: 0 reproduced, 1 not reproduced, 0 undecided at the seeds judged so far, "
            "2 without") in block
    difference, low, high = newcombe_difference_interval(9, 20, 11, 20)
    assert ("fic 9/20 with, 11/20 without; linear" not in block)   # linear has no claim-cell runs: not listed
    assert block.rstrip().endswith(f"fic, with minus without: {difference:+.2f} ({low:+.2f} to {high:+.2f}; "
                                   f"p {boschloo_p(9, 20, 11, 20):.3f}).")
    assert "(`delay_1__rate_10`) (reactive hand), " not in block and "fic 9/20 with, 11/20 without." in block


def test_the_resonant_amplification_the_verdict_found_is_summarised_per_law():
    """The verdict's resonance_gain of each run (kept in claims.json) as a median per law and cell, and on an open-loop
    control in the claims block, so that a forced resonance the verdict does not call an oscillation stays visible."""
    from fic_teleop_experiments.tables import claims_block

    rows = [_row("delay_1__rate_10__feedback_off", "fic", seed, True, hand="reactive") for seed in range(1, 6)]
    for row, gain, period in zip(rows, (1.6, 1.8, 1.7, 2.0, 1.9), (1.5, 1.6, 1.6, 1.7, 1.5)):
        row["verdict"]["figures"] = dict(resonance_gain=gain, resonance_period_s=period)
    rows += [_row("delay_1__rate_10__feedback_off", "linear", seed, True, hand="reactive") for seed in range(1, 6)]
    statistics = claims_statistics(rows, seeds_planned=20)
    laws = statistics["cells"][0]["laws"]
    assert laws["fic"]["resonance_gain_median"] == pytest.approx(1.8)
    assert laws["fic"]["resonance_period_median_s"] == pytest.approx(1.6)
    assert laws["linear"]["resonance_gain_median"] is None
    block = claims_block(statistics)
    assert "Resonant amplification the verdict found on `delay_1__rate_10__feedback_off` (reactive hand" in block
    assert block.rstrip().endswith("fic 1.80 at 1.60 s.")


def test_each_laws_swing_and_tracking_error_stand_beside_its_stable_share():
    """A law that is stable but swings 20 mm is worse for fine work: the tables and the claims block show its swing (the
    verdict's figure) and its RMS tracking error beside its stable share."""
    from fic_teleop_experiments.tables import claims_block, claims_markdown

    rows = [_row("delay_1__rate_10", law, seed, True) for law in ("fic", "linear") for seed in range(1, 21)]
    for row in rows:
        row["verdict"]["figures"] = {"swing_m": 0.020 if row["controller"] == "linear" else 0.004}
        row["figures"]["error_rms_m"] = 0.012 if row["controller"] == "linear" else 0.006
    statistics = claims_statistics(rows, seeds_planned=20)
    (cell,) = statistics["cells"]
    assert cell["laws"]["linear"]["swing_median"] == pytest.approx(0.020)
    table = claims_markdown(statistics)
    assert "| delay_1__rate_10 passive | linear | 20 | 20/20 | 0.84-1.00 | 20.0 / 20.0 | 12.0 / 12.0 | 20/20 |" in table
    block = claims_block(statistics)
    assert "20/20 (0.84-1.00); swing 4 mm, error 6 mm" in block and "linear 20/20; swing 20 mm, error 12 mm" in block
