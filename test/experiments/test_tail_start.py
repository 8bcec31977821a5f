"""Where a claim run's quiet tail begins (fic_teleop_experiments.tail_start) and the claim statistics of the runs
whose tail begins off the fixed obstacle (claims_report --tail-start)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fic_teleop_experiments.claims_report import main as report_main
from fic_teleop_experiments.claims_report import runs_by_tail_start
from fic_teleop_experiments.tail_start import SETTLE_AFTER_LAST_COMMAND_S, classify_runs, tail_begins_on_obstacle
from fic_teleop_experiments.tail_start import main as tail_start_main

TIME = np.arange(0.0, 40.0, 0.02)
QUIET_FROM = 30.0


def _contact(start: float, end: float) -> np.ndarray:
    return (TIME >= start) & (TIME < end)


@pytest.mark.parametrize(("delay", "start", "end", "expected"), [
    (1.0, 30.0, 40.0, True),                                     # on the obstacle as the tail begins
    (1.0, 31.5, 33.0, True),                                     # reached by a command still in flight
    (1.0, 30.0 + 1.0 + SETTLE_AFTER_LAST_COMMAND_S, 40.0, False),  # after the driven start: the free response's
    (0.2, 31.5, 33.0, False),                                    # the same contact, a shorter driven start
    (1.0, 20.0, 29.9, False),                                    # only during the task
])
def test_a_tail_begins_on_the_obstacle_only_when_it_touches_it_in_its_driven_start(delay, start, end, expected):
    assert tail_begins_on_obstacle(TIME, _contact(start, end), QUIET_FROM, delay) is expected


def _write_sweep(folder: Path) -> Path:
    rows = []
    for seed, contact in ((1, (30.0, 40.0)), (2, (0.0, 0.0)), (3, None)):
        key = f"delay_1__rate_10__fic__passive__{seed}__30s__tail_11s"
        rows.append({"key": key, "cell": "delay_1__rate_10", "delay": 1.0, "rate_hz": 10.0, "controller": "fic",
                     "hand": "passive", "seed": seed, "series": key + ".npz",
                     "verdict": {"stable": seed != 1, "safe": True}, "figures": {}})
        if contact is not None:
            np.savez_compressed(folder / (key + ".npz"), time=TIME, obstacle_contact=_contact(*contact),
                                quiet_from=np.asarray(QUIET_FROM))
    judged = folder / "claims.json"
    judged.write_text(json.dumps({"runs": rows}))
    return judged


def test_runs_are_classified_from_their_series_and_a_run_without_one_is_left_out(tmp_path: Path):
    judged = _write_sweep(tmp_path)
    kinds = classify_runs(judged, tmp_path)
    assert [kinds[k]["tail_begins_on_obstacle"] for k in sorted(kinds)] == [True, False, None]

    out = tmp_path / "tail_start.json"
    assert tail_start_main([str(judged), "--series", str(tmp_path), "--out", str(out)]) == 0
    runs = json.loads(judged.read_text())["runs"]
    assert [row["seed"] for row in runs_by_tail_start(runs, out, on_obstacle=False)] == [2]
    assert [row["seed"] for row in runs_by_tail_start(runs, out, on_obstacle=True)] == [1]

    assert report_main([str(judged), "--tail-start", str(out)]) == 0
    statistics = json.loads((tmp_path / "claims_off_obstacle_statistics.json").read_text())
    assert statistics["runs_total"] == 1 and "off the fixed obstacle" in statistics["runs_kept"]
    fic = statistics["cells"][0]["laws"]["fic"]
    assert (fic["stable"]["k"], fic["stable"]["n"]) == (1, 1)


def test_a_series_lost_after_it_was_classified_keeps_its_classification(tmp_path: Path):
    judged = _write_sweep(tmp_path)
    out = tmp_path / "tail_start.json"
    assert tail_start_main([str(judged), "--series", str(tmp_path), "--out", str(out)]) == 0
    on_obstacle_key = "delay_1__rate_10__fic__passive__1__30s__tail_11s"
    (tmp_path / (on_obstacle_key + ".npz")).unlink()          # the series lost with a machine

    assert tail_start_main([str(judged), "--series", str(tmp_path), "--out", str(out)]) == 0
    kinds = json.loads(out.read_text())["runs"]
    assert [kinds[k]["tail_begins_on_obstacle"] for k in sorted(kinds)] == [True, False, None]
    # without the earlier file the lost series cannot be classified
    assert classify_runs(judged, tmp_path)[on_obstacle_key]["tail_begins_on_obstacle"] is None
