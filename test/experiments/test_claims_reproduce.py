"""Re-simulating a kept claim run (fic_teleop_experiments.claims_reproduce): identical when nothing changed, and a
changed figure or series is named."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from fic_teleop_experiments.claims import ClaimRun, execute
from fic_teleop_experiments.claims_reproduce import main

CLAIM = ClaimRun(0.2, 10.0, "fic", "passive", 1, 1.0)


def keep(tmp_path: Path) -> tuple[Path, Path, dict]:
    directory = tmp_path / "runs"
    row = execute(CLAIM, directory, {"commit": "abc"})
    jsonl = tmp_path / "runs.jsonl"
    jsonl.write_text(json.dumps(row) + "\n")
    return directory, jsonl, row


def test_a_kept_run_simulated_again_is_identical(tmp_path: Path, capsys) -> None:
    directory, jsonl, _ = keep(tmp_path)
    assert main([CLAIM.key, "--jsonl", str(jsonl), "--out-dir", str(directory)]) == 0
    assert "identical" in capsys.readouterr().out


def test_a_changed_figure_or_series_is_named(tmp_path: Path, capsys) -> None:
    directory, jsonl, row = keep(tmp_path)
    row["figures"]["peak_force_n"] += 1e-12
    jsonl.write_text(json.dumps(row) + "\n")
    series = directory / row["series"]
    with np.load(series) as data:
        arrays = {name: data[name] for name in data.files}
    arrays["tcp"] = arrays["tcp"].copy()
    arrays["tcp"][-1, 0] += 1e-6
    np.savez_compressed(series, **arrays)
    assert main([CLAIM.key, "--jsonl", str(jsonl), "--out-dir", str(directory)]) == 1
    out = capsys.readouterr().out
    assert "figure peak_force_n" in out and "series tcp" in out


def test_a_field_recorded_only_since_is_named_not_counted(tmp_path: Path, capsys) -> None:
    """A run kept by an older commit lacks the fields a later one added: the arrays both have decide; the new
    fields are named. A field the kept run had and the new one lacks is a difference."""
    directory, jsonl, row = keep(tmp_path)
    series = directory / row["series"]
    with np.load(series) as data:
        arrays = {name: data[name] for name in data.files}
    added = sorted(name for name in arrays if name != "wall_s")[0]
    np.savez_compressed(series, **{name: value for name, value in arrays.items() if name != added})
    assert main([CLAIM.key, "--jsonl", str(jsonl), "--out-dir", str(directory)]) == 0
    out = capsys.readouterr().out
    assert "identical" in out and f"recorded only since: {added}" in out
    np.savez_compressed(series, **arrays, no_longer_recorded=np.zeros(3))
    assert main([CLAIM.key, "--jsonl", str(jsonl), "--out-dir", str(directory)]) == 1
    assert "no longer recorded ['no_longer_recorded']" in capsys.readouterr().out
