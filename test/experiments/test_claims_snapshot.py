"""A claim sweep's frozen copy of one commit (fic_teleop_experiments/claims_snapshot.py): made once from git, the
workspace and the packages pointed at it, and the sweep found where that commit's layout keeps it."""
from __future__ import annotations

import subprocess
from pathlib import Path

from fic_teleop_experiments.claims_snapshot import SPLIT_PACKAGES, prepare, resolve, snapshot_folder


def _repository(root: Path, files: list[str]) -> str:
    """A git repository at ``root`` with ``files`` committed; the commit's full hash."""
    def git(*arguments: str) -> str:
        return subprocess.run(["git", "-C", str(root), *arguments], check=True, capture_output=True,
                              text=True).stdout.strip()

    root.mkdir()
    git("init", "-q")
    for name in files:
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text("# a file of the commit\n")
    git("add", ".")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-q", "-m", "a commit")
    return git("rev-parse", "HEAD")


def test_the_snapshot_is_the_commits_tree_and_the_sweep_runs_from_it(tmp_path: Path) -> None:
    repo = tmp_path / "repo"
    commit = _repository(repo, ["fic_teleop_experiments/fic_teleop_experiments/claims_sweep.py", "config/a.yaml",
                                "sim_bridge/sim_bridge/__init__.py", "fic_core/fic_core/__init__.py"])
    assert resolve(repo, "HEAD") == commit
    command, env = prepare(repo, commit, {"PYTHONPATH": "/elsewhere"})
    snapshot = snapshot_folder(repo, commit)
    assert (snapshot / "COMMIT").read_text().strip() == commit and (snapshot / "config" / "a.yaml").is_file()
    assert command[1:] == ["-m", "fic_teleop_experiments.claims_sweep"]
    assert env["FIC_TELEOP_ROOT"] == str(snapshot)
    paths = env["PYTHONPATH"].split(":")
    assert paths[0] == str(snapshot / "fic_teleop_experiments") and paths[-1] == "/elsewhere"
    assert str(snapshot / "sim_bridge") in paths and str(snapshot / "fic_core") in paths
    absent = [package for package in SPLIT_PACKAGES if package != "fic_teleop_experiments"]
    assert not any(str(snapshot / package) in paths for package in absent)
    (snapshot / "config" / "a.yaml").write_text("the sweep's own copy\n")   # made once: a rerun resumes on it
    prepare(repo, commit, {})
    assert (snapshot / "config" / "a.yaml").read_text() == "the sweep's own copy\n"


def test_an_older_commits_sweep_is_found_where_it_kept_it(tmp_path: Path) -> None:
    script = _repository(tmp_path / "script", ["scripts/claims_sweep.py"])
    command, _ = prepare(tmp_path / "script", script, {})
    assert command[1:] == [str(snapshot_folder(tmp_path / "script", script) / "scripts" / "claims_sweep.py")]
    bridge = _repository(tmp_path / "bridge", ["sim_bridge/sim_bridge/experiments/claims_sweep.py"])
    command, _ = prepare(tmp_path / "bridge", bridge, {})
    assert command[1:] == ["-m", "sim_bridge.experiments.claims_sweep"]
