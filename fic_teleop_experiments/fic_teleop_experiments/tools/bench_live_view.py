"""What the live view costs: the default main job twice, without and with `--live` and the official client
subscribed to every topic for the whole run; each node's CPU time (psutil) and the joint states the recorder
lost (the report's dropped_joint_states). The machine's load is printed with it: on a shared 2-core machine
compare the two runs of one call only.

usage: python -m fic_teleop_experiments.tools.bench_live_view [--duration 30] [--port 8765] [--out
runs/bench-live-<time>]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from datetime import datetime
from pathlib import Path

import psutil

from fic_teleop_runtime.workspace import working_folder

REPO = working_folder()   # runs/ and results/ (FIC_TELEOP_ROOT, else the current folder)
CLIENT = REPO / "test" / "live_view_client"


def _node_name(process: psutil.Process) -> str | None:
    try:
        for argument in process.cmdline():
            if argument.startswith("__node:="):
                return argument.split(":=", 1)[1]
    except psutil.Error:
        return None
    return None


def run(out: Path, duration: float, live_port: int | None) -> dict:
    command = [sys.executable, "-m", "fic_teleop_bringup.teleop_launcher", "--duration", str(duration),
               "--out", str(out), "--no-video"]
    if live_port:
        command += ["--live", "--live-port", str(live_port)]
    launcher = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    cpu: dict[str, float] = {}
    client = None
    load_start = os.getloadavg()[0]
    while launcher.poll() is None:
        for child in psutil.Process(launcher.pid).children(recursive=True):
            name = _node_name(child)
            if name:
                try:
                    times = child.cpu_times()
                    cpu[name] = max(cpu.get(name, 0.0), times.user + times.system)
                except psutil.Error:
                    pass
        if live_port and client is None and "recorder" in cpu:
            # Subscribed for the whole run; the client ends itself a little after the run's length.
            client = subprocess.Popen(["node", str(CLIENT / "client.js"), f"ws://127.0.0.1:{live_port}",
                                       str(duration * 3 + 60)], cwd=CLIENT, stdout=subprocess.PIPE,
                                      stderr=subprocess.DEVNULL, text=True)
        time.sleep(0.2)
    if client is not None:
        client.terminate()
    metrics = json.loads((out / "report" / "metrics.json").read_text())
    run_record = json.loads((out / "run.json").read_text())
    return {"cpu_s": cpu, "dropped_joint_states": metrics.get("dropped_joint_states"),
            "real_time_factor": metrics.get("real_time_factor"), "load_at_start": load_start,
            "load_at_end": os.getloadavg()[0], "wall_s": metrics.get("wall_duration_s"), "run": run_record.get("out")}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--port", type=int, default=8765)
    parser.add_argument("--out", type=Path, default=REPO / "runs" / f"bench-live-{datetime.now():%Y%m%d-%H%M%S}")
    args = parser.parse_args(argv)
    results = {"without": run(args.out / "without", args.duration, None),
               "with_live_view_and_client": run(args.out / "live", args.duration, args.port)}
    (args.out / "bench_live_view.json").write_text(json.dumps(results, indent=2))
    print(json.dumps(results, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
