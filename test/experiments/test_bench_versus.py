"""The alternated bench (fic_teleop_experiments/tools/bench_versus.py): arms taken in turn, each from its own checkout,
the whole process tree's CPU counted, and a directory that is no checkout refused in one line."""
from __future__ import annotations

import argparse
import json
import stat
from pathlib import Path

import pytest

from fic_teleop_experiments.tools import bench_versus

# A stand-in for a checkout's scripts/run_teleop.sh: it books its arm and folder in order.txt, burns CPU in a child
# (the CPU a reaped descendant used must count), and writes the report's metrics.json into its --out folder.
FAKE_MAIN_JOB = """#!/usr/bin/env bash
set -e
echo "$(basename "$PWD") $*" >> "$ORDER_FILE"
out=""; while [[ $# -gt 0 ]]; do [[ $1 == --out ]] && out=$2; shift; done
python3 -c "import time; t = time.process_time() + $BURN_S
while time.process_time() < t: pass"
mkdir -p "$out/report"
echo '{"pipeline_latency_p99_ms": 3.5, "free_motion_error_max_m": 0.0321, "free_motion_error_rms_m": 0.0085}' \\
  > "$out/report/metrics.json"
exit $EXIT_CODE
"""


def _checkout(root: Path, name: str) -> Path:
    script = root / name / "scripts" / "run_teleop.sh"
    script.parent.mkdir(parents=True)
    script.write_text(FAKE_MAIN_JOB)
    script.chmod(script.stat().st_mode | stat.S_IEXEC)
    return root / name


def test_arms_are_taken_in_turn_each_from_its_checkout_with_the_tree_cpu_counted(tmp_path, monkeypatch) -> None:
    old, new = _checkout(tmp_path, "old"), _checkout(tmp_path, "new")
    order = tmp_path / "order.txt"
    monkeypatch.setenv("ORDER_FILE", str(order))
    monkeypatch.setenv("BURN_S", "0.3")
    monkeypatch.setenv("EXIT_CODE", "0")
    arms = [bench_versus.parse_arm(f"OLD={old}", tmp_path), bench_versus.parse_arm(f"NEW={new}:--group a,b", tmp_path)]
    out = tmp_path / "versus.json"
    assert bench_versus.versus(arms, 2, tmp_path / "runs", out) == 0
    lines = order.read_text().splitlines()
    assert [line.split()[0] for line in lines] == ["old", "new", "old", "new"]
    assert lines[1].endswith("--group a,b") and "--no-video" in lines[0]
    result = json.loads(out.read_text())
    assert [run["arm"] for run in result["runs"]] == ["OLD", "NEW", "OLD", "NEW"]
    assert all(0.25 <= run["cpu_s"] < 3.0 for run in result["runs"]), [run["cpu_s"] for run in result["runs"]]
    assert result["summary"]["NEW"]["exit_0"] == 2
    assert result["summary"]["OLD"]["free_motion_error_max_mm"] == [32.1, 32.1, 32.1]


def test_a_failed_run_makes_the_bench_fail_but_keeps_every_run(tmp_path, monkeypatch) -> None:
    checkout = _checkout(tmp_path, "only")
    monkeypatch.setenv("ORDER_FILE", str(tmp_path / "order.txt"))
    monkeypatch.setenv("BURN_S", "0")
    monkeypatch.setenv("EXIT_CODE", "6")
    out = tmp_path / "versus.json"
    assert bench_versus.versus([bench_versus.parse_arm(f"A={checkout}", tmp_path)], 2, tmp_path / "runs", out) == 1
    summary = json.loads(out.read_text())["summary"]["A"]
    assert summary["runs"] == 2 and summary["exit_0"] == 0


def test_a_directory_that_is_no_checkout_and_a_nameless_arm_are_refused(tmp_path) -> None:
    with pytest.raises(argparse.ArgumentTypeError, match="not a checkout"):
        bench_versus.parse_arm(f"A={tmp_path}", tmp_path)
    with pytest.raises(argparse.ArgumentTypeError, match="NAME=DIR"):
        bench_versus.parse_arm(str(tmp_path), tmp_path)
    here = _checkout(tmp_path, "here")
    assert bench_versus.parse_arm("B=.", here).checkout == here
    arm = bench_versus.parse_arm(f"C={here}/../here:--two-stations --duration 20", tmp_path)
    assert arm.checkout == here and arm.launcher_args == ("--two-stations", "--duration", "20")
