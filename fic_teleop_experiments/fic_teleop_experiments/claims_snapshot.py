"""A claim sweep runs, and is judged, on a frozen copy of one commit (docs/EXPERIMENTS.md, "Claims").

    python -m fic_teleop_experiments.claims_snapshot COMMIT [claims_sweep options...]

makes runs/claims_snapshot_<commit>/ (git archive) if it is not there, points the Python packages and the workspace
(FIC_TELEOP_ROOT: its config/ and its COMMIT) at it, and replaces itself with that commit's claim sweep. The code and
the config are the commit's even while the checkout changes, so a sweep that runs for days stays one sweep.
scripts/claims_background.sh starts it detached; claims_refresh.py judges with it.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

#: The packages a newer commit split out of sim_bridge: taken from the snapshot where it has them.
SPLIT_PACKAGES = ("fic_teleop_tools", "fic_teleop_runtime", "fic_teleop_bringup", "fic_teleop_experiments")


def snapshot_folder(repo: Path, commit: str) -> Path:
    return repo / "runs" / f"claims_snapshot_{commit[:12]}"


def prepare(repo: Path, commit: str, environment: dict[str, str] | None = None) -> tuple[list[str], dict[str, str]]:
    """The command line and the environment of ``commit``'s claim sweep (``commit``: a full hash), its snapshot made
    first if it is not there. ``environment``: the one to extend (default: this process's)."""
    snapshot = snapshot_folder(repo, commit)
    if not (snapshot / "COMMIT").is_file():
        snapshot.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", "-C", str(repo), "archive", commit], check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(snapshot)], input=archive, check=True)
        (snapshot / "COMMIT").write_text(commit + "\n")
    env = dict(os.environ if environment is None else environment)
    env["FIC_TELEOP_ROOT"] = str(snapshot)
    paths = [str(snapshot / package) for package in SPLIT_PACKAGES if (snapshot / package / package).is_dir()]
    paths += [str(snapshot / "sim_bridge"), str(snapshot / "fic_core")]
    env["PYTHONPATH"] = os.pathsep.join(paths + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    # Where each era of the code kept the sweep: a script, then sim_bridge, then fic_teleop_experiments.
    if (snapshot / "scripts" / "claims_sweep.py").is_file():
        sweep = [str(snapshot / "scripts" / "claims_sweep.py")]
    elif (snapshot / "sim_bridge" / "sim_bridge" / "experiments" / "claims_sweep.py").is_file():
        sweep = ["-m", "sim_bridge.experiments.claims_sweep"]
    else:
        sweep = ["-m", "fic_teleop_experiments.claims_sweep"]
    return [sys.executable, *sweep], env


def resolve(repo: Path, name: str) -> str:
    """The full hash of ``name`` (a commit, tag or branch of ``repo``); a CalledProcessError if there is none."""
    return subprocess.run(["git", "-C", str(repo), "rev-parse", "--verify", f"{name}^{{commit}}"], check=True,
                          capture_output=True, text=True).stdout.strip()


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not argv or argv[0] in ("-h", "--help"):
        print(__doc__)
        return 0 if argv else 2
    from fic_teleop_runtime.workspace import working_folder

    repo = working_folder()
    try:
        commit = resolve(repo, argv[0])
    except subprocess.CalledProcessError:
        print(f"claims_snapshot: {argv[0]!r} is no commit of {repo}", file=sys.stderr)
        return 2
    command, env = prepare(repo, commit)
    os.execvpe(command[0], [*command, *argv[1:]], env)   # the sweep takes this process (its pid, cgroup, niceness)


if __name__ == "__main__":
    sys.exit(main())
