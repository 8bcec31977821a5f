"""The stress bench's bookkeeping without a graph: a rerun with the same arguments resumes (keeps every finished run,
makes only the missing ones), a bench of other settings is never overwritten, and the quota group gets its high
CPU weight beside its quota (fic_teleop_experiments/tools/stress.py, fic_teleop_experiments/tools/bench.py --stress)."""
from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from fic_teleop_experiments.tools import stress
from fic_teleop_experiments.tools.bench import main as bench_main


def _fake_runs(monkeypatch: pytest.MonkeyPatch, made: list[str], fail_after: int | None = None) -> None:
    """stressed_run and run_figures replaced: each run is recorded by its folder's name; ``fail_after`` runs in,
    the bench is interrupted (KeyboardInterrupt), as an operator's Ctrl-C."""
    def run(launcher_args, out, level, **kwargs):
        if fail_after is not None and len(made) >= fail_after:
            raise KeyboardInterrupt
        out.mkdir(parents=True)
        made.append(out.name)
        return {"exit_code": 6, "wall_s": 1.0, "throttling": {}, "node_moved": None, "shares": kwargs.get("shares"),
                "lock_wait_s": 0.0}

    monkeypatch.setattr(stress, "stressed_run", run)
    monkeypatch.setattr(stress, "run_figures", lambda run_dir, code: {
        "exit_code": code, "flagged_starved": True, "runaway": False, "reasons": [], "lost_tracking": False,
        "limit_violations": 0, "holds": 1, "real_time_factor": 0.9})


def test_a_rerun_with_the_same_arguments_keeps_the_finished_runs_and_makes_only_the_missing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out, runs = tmp_path / "stress.json", tmp_path / "runs"
    arguments = ["--stress", "100,50", "--runs", "3", "--two-stations-runs", "1", "--spare", "recorder",
                 "--out", str(out), "--runs-dir", str(runs), "--launcher-args", "--duration 20"]
    made: list[str] = []
    _fake_runs(monkeypatch, made, fail_after=3)
    with pytest.raises(KeyboardInterrupt):
        bench_main(arguments)
    first = json.loads(out.read_text())
    assert [row["name"] for row in first["runs"]] == made == ["single-100-1", "single-50-1", "two_stations-100-1"]
    made.clear()
    _fake_runs(monkeypatch, made)
    assert bench_main(arguments) == 0
    second = json.loads(out.read_text())
    assert made == ["two_stations-50-1", "single-100-2", "single-50-2", "single-100-3", "single-50-3"]
    assert [row["name"] for row in second["runs"][:3]] == [row["name"] for row in first["runs"]]
    assert len(second["runs"]) == 8 and second["levels"]["single 100"]["runs"] == 3
    assert second["levels"]["two_stations 50"]["runs"] == 1 and len(second["resumed"]) == 1
    made.clear()
    assert bench_main(arguments) == 0 and made == []   # all finished: nothing run again


def test_a_bench_of_other_settings_is_not_overwritten(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                      capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "stress.json"
    made: list[str] = []
    _fake_runs(monkeypatch, made)
    assert bench_main(["--stress", "100", "--runs", "1", "--out", str(out), "--runs-dir", str(tmp_path / "r")]) == 0
    kept = out.read_text()
    assert bench_main(["--stress", "100", "--runs", "1", "--spare", "recorder", "--out", str(out)]) == 2
    assert "other settings (spare: None)" in capsys.readouterr().err
    assert out.read_text() == kept and made == ["single-100-1"]


@pytest.mark.skipif(os.geteuid() != 0, reason="a CPU quota needs root")
def test_the_quota_group_has_a_high_cpu_weight_beside_its_quota() -> None:
    try:
        quota = stress.CpuQuota(50.0)
    except stress.StressError as error:
        pytest.skip(str(error))
    with quota:
        if quota.version == 1:
            assert (quota.path / "cpu.shares").read_text().strip() == str(stress.DEFAULT_SHARES)
            assert (quota.path / "cpu.cfs_quota_us").read_text().strip() == "10000"
        else:
            assert (quota.path / "cpu.weight").read_text().strip() == "800"
    assert not quota.path.exists()
    with pytest.raises(stress.StressError, match="shares"):
        stress.CpuQuota(50.0, shares=1)
