"""A demonstration session: several runs, one episode each, exported as one LeRobot dataset.

A run profile with a ``dataset`` section (profiles/demonstrations.yaml) turns the launcher into this session:
each episode is the launcher itself, run in a child process with the same options into
``<run folder>/episode_<n>`` with seed ``--seed + n - 1``; then the episodes are exported
(fic_teleop_tools.dataset.export, under a lower priority than any run) into ``<run folder>/dataset``. A run's
episode markers (an operator's keep, discard, success, failure) are in its bag, and the export honours them.
An episode whose run kept every safety figure is exported, also when the machine was starved (exit 6: real time
was not kept, the safety figures were); one whose run broke a safety figure (a limit, the velocity reflex, lost
joint states, a crashed node, refused input) is left out and said so: it is no demonstration, and its run folder
says why. An operator's discard marker leaves out any other. The session's exit code is the export's when it
failed (1), else the first failed episode's.
"""
from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from fic_teleop_bringup.launch_supervision import EXIT_CODES, EXIT_OK, EXIT_STARVED

#: The child launcher's flag: run one episode, not a session (hidden from --help).
EPISODE_FLAG = "--episode-of-session"
EXPORT_NICENESS = 10


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--task", default=None,
                        help="the run's task, as a dataset episode's task string (default: the profile's dataset "
                             "task, else the scene's); kept in run.json")
    parser.add_argument(EPISODE_FLAG, action="store_true", help=argparse.SUPPRESS)


def is_session(args: argparse.Namespace) -> bool:
    return bool(args.run_profile.get("dataset")) and not getattr(args, "episode_of_session", False)


def episode_task(args: argparse.Namespace) -> str | None:
    return args.task or (args.run_profile.get("dataset") or {}).get("task")


def run(argv: list[str], args: argparse.Namespace, run_dir: Path) -> int:
    """Run the profile's episodes one after the other, then export them; Ctrl-C stops the episode under way (its
    bag is finalised) and the session, without an export."""
    dataset = args.run_profile["dataset"]
    count = int(dataset.get("episodes", 1))
    run_dir.mkdir(parents=True, exist_ok=True)
    interrupted = False
    child: subprocess.Popen | None = None

    def on_signal(signum, frame) -> None:
        nonlocal interrupted
        interrupted = True
        if child is not None and child.poll() is None:
            child.send_signal(signal.SIGINT)   # the launcher stops its graph in order and finalises the bag

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    episodes, first_failure = [], 0
    try:
        for number in range(1, count + 1):
            if interrupted:
                break
            folder = run_dir / f"episode_{number}"
            print(f"[demonstrations] episode {number} of {count}: {folder}", flush=True)
            command = [sys.executable, "-m", "fic_teleop_bringup.teleop_launcher", *argv, "--out", str(folder),
                       "--seed", str(args.seed + number - 1), EPISODE_FLAG]
            child = subprocess.Popen(command)
            code = child.wait()
            child = None
            if code:
                first_failure = first_failure or code
            if code in (EXIT_OK, EXIT_STARVED) and (folder / "bag").is_dir():
                episodes.append(folder)
                if code:
                    print(f"[demonstrations] episode {number} exited {code} ({EXIT_CODES[code]}); exported",
                          file=sys.stderr)
            elif not interrupted:
                print(f"[demonstrations] episode {number} exited {code} ({EXIT_CODES.get(code, 'no bag')}): left out "
                      "of the dataset; its run folder says why", file=sys.stderr)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    if interrupted:
        print("[demonstrations] interrupted: no export", file=sys.stderr)
        return first_failure or 130
    return export(episodes, run_dir / "dataset", dataset) or first_failure


def export(episodes: list[Path], out: Path, dataset: dict) -> int:
    """Export the episodes in a child process at a lower priority (it renders the camera: seconds of CPU a run)."""
    if not episodes:
        print("[demonstrations] no episode has a bag: nothing to export", file=sys.stderr)
        return 1
    command = [sys.executable, "-m", "fic_teleop_tools.cli", "dataset", "export", *map(str, episodes),
               "--out", str(out)]
    if dataset.get("fps") is not None:
        command += ["--fps", str(dataset["fps"])]
    if dataset.get("size"):
        command += ["--size", str(dataset["size"])]
    started = time.monotonic()
    code = subprocess.run(command, preexec_fn=lambda: os.nice(EXPORT_NICENESS)).returncode
    print(f"[demonstrations] export {'done' if code == 0 else f'failed ({code})'} in "
          f"{time.monotonic() - started:.0f} s: {out}", file=sys.stderr if code else sys.stdout)
    return code
