"""Run one experiment cell through the main job's launcher (real processes over DDS) and analyse its bag.

A cell is one call of the launcher (fic_teleop_bringup.teleop_launcher, what scripts/run_teleop.sh runs) with
``--no-video`` and, unless the cell asks for the paper-style plots, ``--no-report``; the metrics are then computed here
in-process with the report's own definitions (fic_teleop_tools.report: load_bag + analyse, no plots), the run verdict
(fic_teleop_tools.verdict.run_verdict, as for every run), and scene-specific outcomes (E2 pieces) from the same bag.

No rclpy here: the launcher is a child process. Each cell gets a ROS_DOMAIN_ID that no running process on this
machine uses (read from /proc), so a cell never hears someone else's graph.
"""
from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from fic_teleop_runtime.workspace import working_folder
from fic_teleop_tools.verdict.bag_series import RunSeries
from fic_teleop_tools.verdict.run_verdict import VerdictInput, VerdictInputError, judge

REPO = working_folder()   # runs/ and results/ (FIC_TELEOP_ROOT, else the current folder)
#: The launcher (what scripts/run_teleop.sh runs), as an installed module.
LAUNCHER = [sys.executable, "-m", "fic_teleop_bringup.teleop_launcher"]
#: The two controllers every E4 cell is run with: the FIC and the linear baseline of the same stiffness K0.
CONTROLLERS = ("fic", "linear")
_SIM_TIME = re.compile(r"\[run\] sim time\s+([0-9.]+)")
@dataclass
class Cell:
    """One run of the graph: an id, the launcher options, and what to compute from it."""

    id: str
    experiment: str
    options: dict                      # launcher option -> value ("delay": 0.2 -> --delay 0.2)
    report: bool = False               # let the launcher write the paper-style report (plots)
    labels: dict = field(default_factory=dict)  # what the cell varies, for tables and plots

    @property
    def simulated(self) -> float:
        """[s] the simulated time the run lasts: its task (--duration) and its quiet tail (--quiet-tail)."""
        return float(self.options.get("duration", 30.0)) + float(self.options.get("quiet_tail", 0.0))

    def arguments(self) -> list[str]:
        arguments: list[str] = []
        for key, value in self.options.items():
            flag = "--" + key.replace("_", "-")
            if value is True:
                arguments.append(flag)
            elif value is not None and value is not False:
                arguments += [flag, str(value)]
        return arguments


@dataclass
class LaunchOutcome:
    returncode: int
    wall_s: float
    simulated_s: float
    log: Path
    node_errors: str = ""


def launch(cell: Cell, run_dir: Path, *, time_mode: str, on_progress: Callable[[float], None] | None = None,
           timeout: float | None = None) -> LaunchOutcome:
    """Run the launcher for ``cell`` into ``run_dir`` (fresh), reporting simulated seconds as they pass."""
    run_dir.mkdir(parents=True, exist_ok=True)
    command = [*LAUNCHER, *cell.arguments(), "--time-mode", time_mode, "--out", str(run_dir),
               # no --domain-id: the launcher reserves a domain no other run or test holds and no graph is heard on
               # (fic_teleop_bringup/launch_isolation.py; a scan of other processes' ROS_DOMAIN_ID gave two runs one
               # domain)
               "--no-video",
               # lockstep runs at 0.1-0.3x real time on a loaded 2-core machine: let a cell finish
               "--wall-limit", f"{120.0 + 30.0 * cell.simulated:.0f}"]
    if not cell.report:
        command.append("--no-report")
    log_path = run_dir / "launcher.log"
    environment = dict(os.environ, PYTHONUNBUFFERED="1")
    start = time.monotonic()
    simulated = 0.0
    node_errors = ""
    with open(log_path, "w", encoding="utf-8") as log:
        log.write(" ".join(command) + "\n")
        process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                   env=environment, cwd=REPO)
        try:
            for line in process.stdout:
                log.write(line)
                match = _SIM_TIME.search(line)
                if match:
                    simulated = max(simulated, float(match.group(1)))
                    if on_progress:
                        on_progress(simulated)
                stopped = re.search(r"graph stopped after ([0-9.]+) s wall, ([0-9.]+) s simulated(.*)", line)
                if stopped:
                    simulated = float(stopped.group(2))
                    node_errors = stopped.group(3).strip("; ")
                if timeout and time.monotonic() - start > timeout:
                    break
            process.wait(timeout=120)
        except BaseException:
            process.send_signal(signal.SIGINT)  # the launcher stops its graph and finalises the bag on Ctrl-C
            process.wait(timeout=120)
            raise
    if on_progress:
        on_progress(simulated)
    return LaunchOutcome(process.returncode, time.monotonic() - start, simulated, log_path, node_errors)


def report_metrics(bag: Path, quiet_from: float | None = None) -> dict:
    """The report's metrics (docs/EXPERIMENTS.md, "Metrics"; fic_teleop_tools.report), computed in-process without
    plots; with a quiet tail (``quiet_from``, a stamp), its error and force figures are the task's, before it."""
    from fic_teleop_tools.report.bag_data import load_bag
    from fic_teleop_tools.report.metrics import ReportSettings, analyse
    from fic_teleop_tools.report.report import replica_config_defaults

    analysis = analyse(load_bag(bag), ReportSettings(**replica_config_defaults(), quiet_from=quiet_from))
    return analysis.metrics


def stability_of(series: RunSeries, one_way_delay: float, start: float | None = None,
                 end: float | None = None, quiet_from: float | None = None) -> dict:
    """The run verdict (fic_teleop_tools.verdict.run_verdict, the one every run is judged by) of the bag's series, or
    of its [start, end] part in the bag's own time, as a dict; with the tracking error's largest value over the part
    and over its last half, the figures the E4 plots draw. ``quiet_from``: the run's quiet tail (a stamp; the
    verdict judges STABLE by the free response there)."""
    if series.fic_time.size < 8:
        return {"stable": None, "safe": None, "reasons": ["no /replica/fic_state in the bag"]}
    try:
        data = VerdictInput.from_series(series, one_way_delay, quiet_from=quiet_from).window(start, end)
        verdict = judge(data)
    except VerdictInputError as error:
        return {"stable": None, "safe": None, "reasons": [f"not assessable: {error}"]}
    magnitude = np.linalg.norm(np.asarray(data.tracking_error), axis=1)
    time = np.asarray(data.time)
    if data.quiet_from is not None:   # the error figures are the task's; the tail is the verdict's
        task = time < data.quiet_from
        magnitude, time = magnitude[task], time[task]
    last_half = time >= 0.5 * (time[0] + time[-1])
    return {**verdict.as_dict(), "reasons": verdict.reasons, "max_error": float(magnitude.max()),
            "max_error_last_half": float(magnitude[last_half].max())}


def write_json(path: Path, payload) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(payload, indent=2, default=_json_default) + "\n")


def _json_default(value):
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
