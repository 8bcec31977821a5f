"""The E2 sweep's driver (fic_teleop_experiments.e2.sweep): seed-major order, the laws as the runner's controller and
the paper's Eq. 7, resumption from the jsonl (a line cut short by a stopped run is run again), the command line's
engine (one worker unless told), the table's k/n and Wilson intervals, and the failed pieces' contact phases
(e2.outcome.phase_forces)."""
from __future__ import annotations

import contextlib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from fic_teleop_experiments.e2 import sweep as e2_sweep
from fic_teleop_experiments.e2.command_line import main
from fic_teleop_experiments.e2.jsonl import read_rows
from fic_teleop_experiments.e2.outcome import phase_forces
from fic_teleop_experiments.engine import Engine


def _row(seed: int, inside: list[str], peak: float = 12.0) -> dict:
    return {"seed": seed, "pieces_inside": inside, "peak_force_n": peak, "time_above_f_max_s": 0.5,
            "limit_violations": 0, "wall_s": 1.0, "retries": 0, "verdict": {"stable": True, "safe": True},
            "pieces": {"cuboid": {"result": "inside" if "cuboid" in inside else "gave up", "duration_s": 40.0,
                                  "grasps": 1, "insertions": 2, "phases": [("pulled", 30.0, 7.5)]}},
            "trace": {"time": [0.0, 10.0, 20.0, 30.0, 40.0], "force_n": [0.0, 3.0, 11.0, 12.6, 0.5],
                      "error_m": [0.0, 0.01, 0.06, 0.07, 0.0],
                      "phases": [("cuboid:reach", 0.0), ("cuboid:lock", 15.0), ("cuboid:pull", 25.0),
                                 ("cuboid:pulled", 35.0)]}}


def test_the_sweep_runs_seed_major_and_resumes_from_its_jsonl(tmp_path: Path, monkeypatch) -> None:
    calls = []

    def fake_trial(seed, duration, jitter, operator, controller, delay, paper_law=None):
        calls.append((seed, controller, paper_law, delay))
        return _row(seed, ["cuboid"])

    monkeypatch.setattr(e2_sweep, "trial", fake_trial)
    out = tmp_path / "sweep.jsonl"
    cells = [("fic_paper_law", 0.2), ("linear", 1.0)]
    with ThreadPoolExecutor(max_workers=1) as executor:   # the default engine's one worker, in this process
        assert e2_sweep.run_cells(out, cells, 2, 10.0, executor) == 4
    assert calls == [(1, "fic", True, 0.2), (1, "linear", False, 1.0), (2, "fic", True, 0.2), (2, "linear", False, 1.0)]
    assert [(row["law"], row["seed"]) for row in read_rows(out)] == \
        [("fic_paper_law", 1), ("linear", 1), ("fic_paper_law", 2), ("linear", 2)]
    # A stopped run: its last line cut short. The rerun keeps the three whole trials and runs the fourth again.
    lines = out.read_text().splitlines()
    out.write_text("\n".join(lines[:3]) + "\n" + lines[3][:40])
    calls.clear()
    with ThreadPoolExecutor(max_workers=1) as executor:
        assert e2_sweep.run_cells(out, cells, 2, 10.0, executor) == 1
    assert calls == [(2, "linear", False, 1.0)]
    rows = read_rows(out)
    assert sorted((row["law"], row["seed"]) for row in rows) == [("fic_paper_law", 1), ("fic_paper_law", 2),
                                                                 ("linear", 1), ("linear", 2)]


def test_the_command_line_runs_its_cells_on_one_engine_worker_unless_told(tmp_path: Path, monkeypatch) -> None:
    opened = []

    @contextlib.contextmanager
    def engine(args):
        opened.append((args.workers, args.engine, args.cluster))
        with ThreadPoolExecutor(max_workers=args.workers) as executor:
            yield Engine(executor=executor, name="pool", address=None, workers=args.workers)

    monkeypatch.setattr(e2_sweep, "trial", lambda seed, *args, **kwargs: _row(seed, ["cuboid"]))
    monkeypatch.setattr(e2_sweep, "engine_from_arguments", engine)
    out = tmp_path / "sweep.jsonl"
    assert main(["sweep", "--out", str(out), "--seeds", "2", "--cells", "linear@1"]) == 0
    assert main(["sweep", "--out", str(out), "--seeds", "3", "--cells", "linear@1", "--workers", "2"]) == 0
    assert opened == [(1, None, None), (2, None, None)]
    assert sorted(row["seed"] for row in read_rows(out)) == [1, 2, 3]


def test_the_table_gives_k_of_n_with_wilson_intervals() -> None:
    rows = [dict(_row(seed, ["cuboid", "octagonal_prism", "star_prism"] if seed < 4 else ["cuboid"]),
                 law="fic", delay_s=0.2) for seed in range(1, 5)]
    table = e2_sweep.summary(rows)
    line = next(line for line in table.splitlines() if line.startswith("| fic | 0.2 |"))
    assert "| 3/4 (0.30-0.95) |" in line       # 3 of 4 trials: Wilson 95 % 0.30-0.95
    assert "| 10/12 (0.55-0.95) |" in line     # 10 of 12 pieces
    assert "| 4/4 / 4/4 |" in line             # stable / safe


def test_a_failed_piece_shows_its_contact_phases_forces_and_errors() -> None:
    row = _row(3, [])
    assert phase_forces(row) == [("cuboid:lock", 15.0, 25.0, 11.0, 0.06), ("cuboid:pull", 25.0, 35.0, 12.6, 0.07)]
    text = e2_sweep.why([dict(row, law="fic", delay_s=0.2)])
    assert "fic@0.2 seed 3: 0/3 inside; not inside: cuboid" in text
    assert "felt in each pull [N]: [7.5]" in text
    assert "peak |F_R|  12.6 N  max |x_d - x_R|  70.0 mm" in text


@pytest.mark.parametrize("cell", ["fic", "fic@x", "pid@0.2", "fic@9"])
def test_a_malformed_cell_is_refused(cell: str) -> None:
    with pytest.raises(SystemExit):
        main(["sweep", "--out", "/tmp/unused.jsonl", "--cells", cell])


def test_the_default_cells_are_every_law_at_every_delay_the_paper_s_first() -> None:
    cells = [e2_sweep.parse_cell(cell) for cell in e2_sweep.DEFAULT_CELLS]
    assert sorted(cells) == sorted((law, delay) for law in e2_sweep.LAWS for delay in (0.0, 0.2, 0.5, 1.0))
    assert cells[:len(e2_sweep.LAWS)] == [(law, 0.2) for law in e2_sweep.LAWS]
