"""The claims document from a run file: counts, dedup of resumed runs, unfinished runs, the comparisons, the tables
and the figures."""
from __future__ import annotations

import json

import pytest

from sim_bridge.experiments.cell_statistics import boschloo_p, fisher_p, newcombe_difference_interval, wilson_interval
from sim_bridge.experiments.claims_report import claims_document, main, read_runs


def _row(cell: str, law: str, seed: int, stable, safe=True, **extra) -> dict:
    return dict(cell=cell, controller=law, seed=seed, stable=stable, safe=safe, error_rms_m=0.001 * seed,
                error_max_m=0.01 * seed, peak_force_n=float(seed), delay_s=1.0, **extra)


def _runs() -> list[dict]:
    rows = [_row("delay_1_rate_10", "fic", seed, True) for seed in range(1, 21)]
    rows += [_row("delay_1_rate_10", "linear", seed, seed <= 12, safe=seed != 3) for seed in range(1, 21)]
    rows += [_row("delay_1_rate_10", "linear_tdpa", seed, None if seed == 1 else True) for seed in range(1, 6)]
    return rows


def test_counts_and_comparisons_match_the_statistics():
    document = claims_document(_runs(), seeds_planned=20)
    (cell,) = document["cells"]
    assert cell["cell"] == "delay_1_rate_10" and cell["delay_s"] == 1.0
    fic, linear, tdpa = cell["laws"]["fic"], cell["laws"]["linear"], cell["laws"]["linear_tdpa"]
    assert (fic["stable"]["k"], fic["stable"]["n"]) == (20, 20)
    assert (linear["stable"]["k"], linear["stable"]["n"], linear["safe"]["k"]) == (12, 20, 19)
    assert linear["stable"]["interval_95"] == pytest.approx(wilson_interval(12, 20))
    assert (tdpa["stable"]["k"], tdpa["stable"]["n"], tdpa["runs"]) == (4, 4, 5)   # seed 1 not judged
    assert linear["seeds"] == list(range(1, 21))
    assert linear["error_rms_median"] == pytest.approx(0.0105)
    assert linear["peak_force_p95"] == pytest.approx(19.05)
    comparison = next(c for c in document["comparisons"] if c["baseline"] == "linear")
    stable = comparison["stable"]
    assert stable["difference"] == pytest.approx(0.4)
    assert stable["difference_interval_95"] == pytest.approx(newcombe_difference_interval(20, 20, 12, 20)[1:])
    assert stable["boschloo_p"] == pytest.approx(boschloo_p(20, 20, 12, 20))
    assert stable["fisher_p"] == pytest.approx(fisher_p(20, 20, 12, 20))
    assert {c["baseline"] for c in document["comparisons"]} == {"linear", "linear_tdpa"}
    assert document["runs_total"] == 45 and len(document["runs"]) == 45


def test_operator_and_hand_split_cells_and_a_cell_without_the_fic_has_no_comparison():
    rows = [_row("c", "fic", 1, True, hand="passive"), _row("c", "fic", 1, False, hand="reactive"),
            _row("d", "linear", 1, True)]
    document = claims_document(rows)
    assert sorted((c["cell"], c.get("hand")) for c in document["cells"]) == [("c", "passive"), ("c", "reactive"),
                                                                           ("d", None)]
    assert document["comparisons"] == []


def test_run_file_keeps_the_last_line_of_a_run_skips_torn_lines_and_counts_failures(tmp_path):
    path = tmp_path / "claims_runs.jsonl"
    lines = [json.dumps(_row("c", "fic", 1, False)), json.dumps(_row("c", "fic", 1, True)),
             json.dumps(dict(cell="c", controller="linear", seed=1, failure="RuntimeError: boom")), '{"cell": "c", "con']
    path.write_text("\n".join(lines) + "\n")
    runs = read_runs(path)
    assert len(runs) == 2
    document = claims_document(runs)
    laws = document["cells"][0]["laws"]
    assert (laws["fic"]["stable"]["k"], laws["fic"]["stable"]["n"]) == (1, 1)
    assert (laws["linear"]["runs"], laws["linear"]["finished"], laws["linear"]["stable"]["n"]) == (1, 0, 0)
    assert document["comparisons"][0]["stable"]["difference"] is None


def test_command_line_writes_the_json_tables_and_figures(tmp_path, capsys):
    path = tmp_path / "claims_runs.jsonl"
    path.write_text("".join(json.dumps(row) + "\n" for row in _runs()))
    assert main([str(path), "--seeds-planned", "20"]) == 0
    document = json.loads((tmp_path / "claims.json").read_text())
    assert document["seeds_planned"] == 20 and document["runs_finished"] == 45
    tables = (tmp_path / "claims_tables.md").read_text()
    assert "| delay_1_rate_10 | linear | 20 | 12/20 | 0.39-0.78 |" in tables
    assert "| delay_1_rate_10 | linear | stable | 20/20 | 12/20 | +0.40 |" in tables
    for name in ("claims_proportions.png", "claims_differences.png"):
        assert (tmp_path / name).stat().st_size > 10_000
    with pytest.raises(SystemExit):
        main([str(tmp_path / "missing.jsonl")])
