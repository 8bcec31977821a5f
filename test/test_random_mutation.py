"""The seeded random mutation run (sim_bridge/tools/random_mutation.py) on a loaded machine: test/core that does not
finish on the unmutated tree is one clear line and exit 2 (not a traceback), and kills by the timeout are counted
apart, as a slow run and a hang look alike when the machine is starved. The pytest runs are replaced: what is
checked is the tool's own accounting."""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from sim_bridge.tools import random_mutation
from sim_bridge.tools.random_mutation import KILLED, Site


def _site(line: int) -> Site:
    return Site("limits.py", line, line, "comparison", "< -> <=", f"a < b  # {line}")


def test_test_core_that_does_not_finish_on_the_unmutated_tree_is_one_line_and_exit_2(monkeypatch, capsys) -> None:
    def slow(root: Path, folder: str, files: list[Path], timeout: float) -> subprocess.CompletedProcess:
        raise subprocess.TimeoutExpired(["pytest"], timeout)

    monkeypatch.setattr(random_mutation, "snapshot", lambda commit, folder: random_mutation.REPO)
    monkeypatch.setattr(random_mutation, "_pytest", slow)
    with pytest.raises(RuntimeError, match="did not finish on the unmutated tree in 7 s"):
        random_mutation.baseline(random_mutation.REPO, 7.0)
    assert random_mutation.main(["--seed", "2", "--sample", "3", "--baseline-timeout", "7"]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "--baseline-timeout" in error[0], error


def test_kills_by_the_timeout_are_counted_apart(monkeypatch, tmp_path: Path) -> None:
    sites = [_site(10), _site(20), _site(30), _site(40)]
    verdicts = {10: (KILLED, "test/core/test_limits.py::test_edge", 3.0),
                20: (KILLED, f"{random_mutation.TIMEOUT_DETAIL} 900 s (a hang counts)", 900.0),
                30: ("SURVIVED", "every test passed", 4.0),
                40: (KILLED, f"{random_mutation.TIMEOUT_DETAIL} 900 s (a hang counts)", 900.0)}
    monkeypatch.setattr(random_mutation, "snapshot", lambda commit, folder: random_mutation.REPO)
    monkeypatch.setattr(random_mutation, "baseline",
                        lambda root, timeout: subprocess.CompletedProcess(["pytest"], 0, "9 passed", ""))
    monkeypatch.setattr(random_mutation, "all_sites", lambda root: sites)
    monkeypatch.setattr(random_mutation, "sample", lambda seed, size, module, root: sites)
    monkeypatch.setattr(random_mutation, "equivalent_mutants", lambda: {})
    monkeypatch.setattr(random_mutation, "run_mutant", lambda site, timeout, root: verdicts[site.line])
    result = random_mutation.run(2, 4, 900.0, out=tmp_path / "out.json", echo=lambda text: None)
    assert (result["killed"], result["killed_by_timeout"], result["non_equivalent"]) == (3, 2, 4)
    assert result["kill_rate"] == 0.75


def test_a_rerun_carries_the_seed_of_the_run_whose_survivors_it_reruns(monkeypatch, tmp_path: Path) -> None:
    earlier = tmp_path / "seed5.json"
    earlier.write_text('{"seed": 5, "mutants": []}')
    seen = {}

    def fake_run(seed, size, timeout, module, out, **kwargs) -> dict:
        seen["seed"], seen["rerun"] = seed, kwargs["rerun"]
        return {"commit": "0" * 40, "seed": seed, "sample": 0, "sites": 0, "equivalent": 0, "non_equivalent": 0,
                "killed": 0, "killed_by_timeout": 0, "kill_rate": None, "seconds": 0, "mutants": []}

    monkeypatch.setattr(random_mutation, "run", fake_run)
    random_mutation.main(["--rerun", str(earlier), "--require", "0"])
    assert seen == {"seed": 5, "rerun": {"seed": 5, "mutants": []}}
