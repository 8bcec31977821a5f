"""The E2 graph's tables (python -m fic_teleop_experiments.e2 graph --table, --agreement): the graph's laws in the
sweep's table and each graph trial beside the runner's trial of the same law, delay and seed."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from fic_teleop_experiments.e2 import graph as e2_graph
from fic_teleop_experiments.e2.command_line import main


def _row(law: str, seed: int, inside: int, peak: float, task: float | None, stable: bool = True) -> dict:
    names = ["cuboid", "octagonal_prism", "star_prism"]
    return {"law": law, "delay_s": 0.2, "seed": seed, "pieces_inside": [f"piece_{n}" for n in names[:inside]],
            "peak_force_n": peak, "time_above_f_max_s": 1.5, "retries": 3 - inside, "limit_violations": 0,
            "task_time_s": task, "verdict": {"stable": stable, "safe": True},
            "pieces": {name: {"result": "inside" if index < inside else "gave up", "duration_s": 30.0 + index}
                       for index, name in enumerate(names)}}


def test_each_graph_trial_stands_beside_the_runner_s_same_cell_and_seed() -> None:
    graph = [_row("linear", 3, 3, 45.0, 110.5), _row("fic", 3, 0, 48.6, None), _row("fic", 9, 3, 40.0, 100.0)]
    runner = [_row("fic", 3, 3, 30.5, 123.9, stable=False), _row("linear", 3, 3, 44.0, 108.0)]
    lines = e2_graph.agreement(graph, runner).splitlines()
    assert len(lines) == 4   # header, rule, fic seed 3, linear seed 3: seed 9 has no runner trial
    assert lines[2] == ("| fic@0.2 | 3 | 0 / 3 | 3 / 0 | - / 123.9 | - / 30.0-32.0 | 48.6 / 30.5 | 1.5 / 1.5 | "
                        "yes, yes / no, yes |")
    assert lines[3].startswith("| linear@0.2 | 3 | 3 / 3 | 0 / 0 | 110.5 / 108.0 | 30.0-32.0 / 30.0-32.0 |")


def test_the_table_reads_several_graph_files_and_needs_no_trials_file(tmp_path: Path, capsys) -> None:
    files = []
    for law, rows in (("fic", [_row("fic", 1, 3, 44.0, 101.0), _row("fic", 3, 0, 48.6, None)]),
                      ("linear", [_row("linear", 1, 3, 45.0, 99.0)])):
        files.append(tmp_path / f"{law}.jsonl")
        files[-1].write_text("".join(json.dumps(row) + "\n" for row in rows))
    assert main(["graph", "--table", *map(str, files)]) == 0
    table = capsys.readouterr().out
    assert "| fic | 0.2 | 1/2 (0.09-0.91) | 3/6 (0.19-0.81) |" in table
    assert "| linear | 0.2 | 1/1 (0.21-1.00) | 3/3 (0.44-1.00) |" in table


def test_running_without_a_trials_file_or_an_agreement_without_graph_files_is_refused() -> None:
    with pytest.raises(SystemExit):
        main(["graph", "--seeds", "1"])
    with pytest.raises(SystemExit):
        main(["graph", "--agreement", "results/e2_sweep.jsonl"])
