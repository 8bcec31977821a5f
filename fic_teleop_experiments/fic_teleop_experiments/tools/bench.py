"""Benchmarks of the whole system (docs/EXPERIMENTS.md, "Benchmarks"); prints a table and writes results/bench.json.

    scripts/bench.sh [--runs 10] [--lockstep-duration 10] [--out results/bench.json]

1. Replica tick compute (median, p99): bench_core.py (the control law alone, in process).
2. The default main job, timed end to end: `scripts/run_teleop.sh` with its defaults (superimposition, 200 ms, 30 s,
   realtime, report included; only --out is added, the launcher reserves the domain). While it runs, every node process
   the launcher started is sampled with psutil every 0.5 s: CPU share (CPU seconds / wall seconds, 100 % = one core)
   and peak resident memory (RSS). From its metrics.json: pipeline latency (median, p99) and real-time factor; from
   its bag: the realtime step lateness of the robot sim (/sim/step_lateness, the worst step of each 0.1 s, and the
   robot_sim diagnostics' 10 s p50/p99); and the achieved rate of every loop as a fraction of its nominal rate
   (fic_teleop_tools/report/loop_rates.py). `--runs N` runs it N times in a row and counts how many runs met each target
   (latency p99 < 5 ms in 8 of 10, every loop >= 95 % in 8 of 10, no lost joint state, no limit violation and the
   free-motion error bounds in all).
3. Lockstep: the same graph in lockstep (--time-mode lockstep, --no-report): physics steps per wall second with the
   whole graph answering every step (report's real_time_factor x 1000), with the same per-node sampling.

Every figure depends on the machine's load (a 2-core VM shared with other work): the load average is written next
to them.

--versus NAME=DIR[:ARGS] ... instead runs whole main jobs of several checkouts or launcher options in turn, --runs
rounds (bench_versus.py; results/bench_versus.json): the way to compare A and B on a VM whose speed drifts.

--stress LEVELS (e.g. 150,100,70,50: % of one CPU) instead runs the starvation harness
(fic_teleop_experiments/tools/stress.py): per level, --runs single-host runs and --two-stations-runs two-station runs of
the default main job under a cgroup CPU quota at that level (the whole graph, or --stress-node alone; optional pinned
--hogs), the levels taken in turn so that a change of the machine's load falls on all of them, and per level: runaways,
runs with limit violations (and how many of those held), the replica's holds, RTF, the slowest loop, the free-motion
error, the exit codes and how many runs the launcher flagged as starved (exit 6). Written to results/stress.json by
default. Needs root.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shlex
import shutil
import subprocess
import sys
import threading
import time
from datetime import datetime
from pathlib import Path

import numpy as np
import psutil

from fic_teleop_experiments.runner import write_json
from fic_teleop_runtime.workspace import working_folder
from fic_teleop_tools.report.metrics import TARGETS as REPORT_TARGETS
from fic_teleop_tools.verdict.bag_series import read_run

REPO = working_folder()   # runs/ and results/ (FIC_TELEOP_ROOT, else the current folder)

LAUNCHER_PROCESS = "launcher"      # the sampler's root: scripts/run_teleop.sh execs the launcher
LAUNCHER_NODE = "fic_teleop_launcher"   # its node on the graph (it reads /clock)


class NodeSampler(threading.Thread):
    """Samples the CPU time and RSS of every descendant of ``root`` (the launcher) until stopped."""

    def __init__(self, root: int, period: float = 0.5) -> None:
        super().__init__(daemon=True)
        self.root, self.period = root, period
        self.stats: dict[str, dict] = {}
        self._halt = threading.Event()

    @staticmethod
    def process_name(process: psutil.Process) -> str | None:
        try:
            command = process.cmdline()
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            return None
        names = [item.split("=", 1)[1] for item in command if item.startswith("__node:=")]
        if names:
            return "+".join(names)   # several: a group of nodes in one process (the launcher's --group)
        if any("fic_teleop_tools.report" in item for item in command):
            return "report"
        if "fic_teleop_bringup.rtps_traffic" in command:
            return "link capture"            # --two-stations: the capture of the link's traffic
        if "fic_teleop_bringup.teleop_launcher" in command:
            return "launcher (robot station)"   # --two-stations: the launcher inside the robot station
        return None

    def run(self) -> None:
        try:
            root = psutil.Process(self.root)
        except psutil.NoSuchProcess:
            return
        while not self._halt.is_set():
            try:
                children = root.children(recursive=True)
            except psutil.NoSuchProcess:
                break
            now = time.monotonic()
            for child in [root, *children]:
                name = LAUNCHER_PROCESS if child is root else self.process_name(child)
                if name is None:
                    continue
                try:
                    with child.oneshot():
                        times = child.cpu_times()
                        rss = child.memory_info().rss
                except (psutil.NoSuchProcess, psutil.AccessDenied):
                    continue
                cpu = times.user + times.system
                entry = self.stats.setdefault(name, {"pid": child.pid, "first_t": now, "first_cpu": cpu,
                                                     "last_t": now, "last_cpu": cpu, "peak_rss": rss})
                entry["last_t"], entry["last_cpu"] = now, cpu
                entry["peak_rss"] = max(entry["peak_rss"], rss)
            self._halt.wait(self.period)

    def stop(self) -> dict[str, dict]:
        self._halt.set()
        self.join(timeout=5.0)
        table = {}
        for name, entry in sorted(self.stats.items()):
            span = entry["last_t"] - entry["first_t"]
            table[name] = {"cpu_percent_of_one_core": round(100.0 * (entry["last_cpu"] - entry["first_cpu"]) / span, 1)
                           if span > 1.0 else None,
                           "cpu_s": round(entry["last_cpu"] - entry["first_cpu"], 2),
                           "peak_rss_mb": round(entry["peak_rss"] / 2 ** 20, 1), "sampled_s": round(span, 1)}
        return table


def machine_shares(before, after) -> dict:
    """The machine's CPU time between two psutil.cpu_times() readings, in % of all cores: steal is the time the
    hypervisor gave this VM's vCPUs to others (a shared host), which no niceness of ours can win back."""
    fields = ("user", "system", "idle", "iowait", "steal")
    total = sum(getattr(after, name) - getattr(before, name) for name in after._fields)
    return {f"{name}_percent": round(100.0 * (getattr(after, name, 0.0) - getattr(before, name, 0.0)) / total, 1)
            for name in fields} if total > 0 else {}


def run_sampled(command: list[str], log_path: Path, while_running=None, cwd: Path = REPO) -> tuple[int, float, dict]:
    """Run ``command`` (from ``cwd``) with its processes sampled (NodeSampler); ``while_running(pid)`` runs on a
    thread beside it.
    The table gains "main job", the whole process tree's CPU (every descendant's user + system time as the kernel
    counts it when they are reaped: the setup check, the launcher, the nodes, the report)."""
    start = time.monotonic()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(log_path, "w", encoding="utf-8") as log:
        process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, cwd=cwd,
                                   env=dict(os.environ, PYTHONUNBUFFERED="1"))
        sampler = NodeSampler(process.pid)
        sampler.start()
        helper = threading.Thread(target=while_running, args=(process.pid,), daemon=True) if while_running else None
        if helper is not None:
            helper.start()
        code = process.wait()
        if helper is not None:
            helper.join(timeout=30.0)
    wall = time.monotonic() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    table = sampler.stop()
    table[MAIN_JOB] = {"cpu_s": round(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, 2),
                       "user_s": round(after.ru_utime - before.ru_utime, 2),
                       "system_s": round(after.ru_stime - before.ru_stime, 2), "wall_s": round(wall, 1)}
    return code, wall, table


MAIN_JOB = "main job"   # the whole process tree's row in a node table


def census_when_up(run_dir: Path, out: Path, settle_s: float = 12.0):
    """A ``while_running`` for run_sampled: once the launcher has written its domain (run.json) and the nodes have
    run ``settle_s`` seconds, the graph census (graph_census.py) of that domain into ``out``."""
    def take(pid: int) -> None:
        deadline = time.monotonic() + 120.0
        domain = None
        while domain is None and time.monotonic() < deadline and psutil.pid_exists(pid):
            try:
                domain = json.loads((run_dir / "run.json").read_text()).get("domain_id")
            except (OSError, ValueError):
                pass
            time.sleep(0.5)
        if domain is None:
            return
        time.sleep(settle_s)
        if psutil.pid_exists(pid):
            subprocess.run([sys.executable, "-m", "fic_teleop_experiments.tools.graph_census", "--domain", str(domain),
                            "--out", str(out)], cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                           timeout=60)
    return take


def cpu_budget(nodes: dict[str, dict], metrics: dict, census: dict | None) -> dict:
    """Per process: CPU-s in all and per simulated second of the bag (metrics' duration_s), and the messages a
    second it publishes and receives (graph_census.message_budget over the bag's counts and wall span)."""
    from fic_teleop_experiments.tools.graph_census import message_budget

    simulated = metrics.get("duration_s") or 0.0
    # A node's second, unspun node (the recorder's ``recorder_reader``, which holds its subscriptions) is its process's.
    processes = {name: ([LAUNCHER_NODE] if name == LAUNCHER_PROCESS else
                        [member for node in name.split("+") for member in (node, f"{node}_reader")])
                 for name in nodes if name not in (MAIN_JOB, "report")}
    messages, unrecorded = message_budget(census or {}, metrics.get("message_counts") or {},
                                          metrics.get("wall_duration_s") or 0.0, processes)
    rows = {}
    for name, row in nodes.items():
        rows[name] = {"cpu_s": row["cpu_s"],
                      "cpu_s_per_simulated_s": round(row["cpu_s"] / simulated, 3) if simulated else None,
                      **(messages.get(name, {}) if census else {})}
    return {"simulated_s": simulated, "processes": rows, "census": census is not None,
            "topics_not_in_the_bag": unrecorded if census else None}


def bench_core(ticks: int, out: Path) -> dict:
    path = out / "bench_core.json"
    subprocess.run([sys.executable, "-m", "fic_teleop_experiments.tools.bench_core", "--ticks", str(ticks), "--json",
                    str(path)],
                   check=True, cwd=REPO, stdout=subprocess.DEVNULL)
    return json.loads(path.read_text())


def lateness(bag: Path) -> dict:
    series = read_run(bag)
    robot = series.diagnostics.get("robot_sim", {})
    figures = {key: float(robot[key]) for key in ("lateness_p50_ms", "lateness_p99_ms", "lateness_max_ms",
                                                  "achieved_rate_hz") if key in robot}
    if "overruns" in robot:
        figures["overruns"] = int(robot["overruns"])
    values = _step_lateness(bag)
    if values.size:
        figures["step_lateness_topic_worst_per_100ms_median_ms"] = float(np.median(values) * 1e3)
        figures["step_lateness_topic_worst_per_100ms_p99_ms"] = float(np.percentile(values, 99) * 1e3)
        figures["step_lateness_topic_samples"] = int(values.size)
    return figures


def _step_lateness(bag: Path) -> np.ndarray:
    import struct

    from fic_teleop_tools.recording.bag_reader import read_messages

    values = []
    for _, channel, message in read_messages(bag):
        if channel.topic == "/sim/step_lateness":
            little = message.data[1] & 1
            values.append(struct.unpack_from("<d" if little else ">d", message.data, 4)[0])  # std_msgs/Float64
    return np.asarray(values)

#: The targets of the default main job on this machine (module docstring, 2.): per run, and how many of
#: the runs must meet each. The latency and error bounds are the report's (fic_teleop_tools/report/metrics.py), kept
#: there once; "every loop >= 95 %" is this bench's own, stricter than the launcher's "starved" bound (90 %).
_LATENCY_P99_MS = REPORT_TARGETS["pipeline_latency_p99_ms"][1]
_ERROR_MAX_M = REPORT_TARGETS["free_motion_error_max_m"][1]
_ERROR_RMS_M = REPORT_TARGETS["free_motion_error_rms_m"][1]
TARGETS = {
    f"latency p99 < {_LATENCY_P99_MS:g} ms":
        (lambda run: (run["pipeline_latency_p99_ms"] or float("inf")) < _LATENCY_P99_MS, 0.8),
    "every loop >= 95 % of nominal": (lambda run: (run["slowest_loop_fraction"] or 0.0) >= 0.95, 0.8),
    "0 lost joint states": (lambda run: run["dropped_joint_states"] == 0, 1.0),
    "0 limit violations": (lambda run: run["metrics"].get("limit_violations") == 0, 1.0),
    f"free-motion error max < {_ERROR_MAX_M * 1e3:g} mm":
        (lambda run: (run["metrics"].get("free_motion_error_max_m") or 1.0) < _ERROR_MAX_M, 1.0),
    f"free-motion error RMS < {_ERROR_RMS_M * 1e3:g} mm":
        (lambda run: (run["metrics"].get("free_motion_error_rms_m") or 1.0) < _ERROR_RMS_M, 1.0),
}


def default_run(run_dir: Path, log_path: Path, launcher_args: list[str] = (), checkout: Path = REPO,
                census: bool = True) -> dict:
    """One default main job (module docstring, 2.) with the loop rates of its bag; ``launcher_args`` for an A/B
    (e.g. --group); ``checkout``: whose scripts/run_teleop.sh, started from there (bench_versus.py); ``census``: take
    the graph census while it runs (the messages a second of each process)."""
    from fic_teleop_tools.report.loop_rates import loop_rates

    # No --domain-id: the launcher reserves one no other run or test holds (fic_teleop_bringup.launch_isolation).
    command = [str(checkout / "scripts" / "run_teleop.sh"), "--out", str(run_dir), *launcher_args]
    cpu_before, load_before = psutil.cpu_times(), list(os.getloadavg())
    census_path = log_path.with_suffix(".census.json")
    code, wall, nodes = run_sampled(command, log_path, census_when_up(run_dir, census_path) if census else None,
                                    cwd=checkout)
    machine = machine_shares(cpu_before, psutil.cpu_times())
    metrics_path = run_dir / "report" / "metrics.json"
    metrics = json.loads(metrics_path.read_text()) if metrics_path.exists() else {}
    census = json.loads(census_path.read_text()) if census_path.exists() else None
    bag = run_dir / "bag"
    rates = loop_rates(bag, run_dir) if bag.exists() else {}
    fractions = [row["fraction"] for row in rates.values() if row["fraction"] is not None]
    return {"exit_code": code, "wall_s": round(wall, 1),
            "pipeline_latency_p50_ms": metrics.get("pipeline_latency_p50_ms"),
            "pipeline_latency_p99_ms": metrics.get("pipeline_latency_p99_ms"),
            "real_time_factor": metrics.get("real_time_factor"),
            "dropped_joint_states": metrics.get("dropped_joint_states"),
            "loop_rates": rates, "slowest_loop_fraction": min(fractions) if fractions else None,
            "realtime_step_lateness": lateness(bag) if bag.exists() else None,
            "nodes": nodes, "cpu_budget": cpu_budget(nodes, metrics, census),
            "load_average_before": load_before, "load_average_after": list(os.getloadavg()),
            "machine_cpu_during_run": machine, "metrics": metrics}


def summary(runs: list[dict]) -> dict:
    """How many of the runs met each target, and the spread of the headline figures."""
    met = {name: sum(bool(check(run)) for run in runs) for name, (check, _) in TARGETS.items()}
    required = {name: int(np.ceil(share * len(runs))) for name, (_, share) in TARGETS.items()}

    def spread(values: list) -> list | None:
        values = [v for v in values if v is not None]
        return [round(float(min(values)), 3), round(float(np.median(values)), 3), round(float(max(values)), 3)] \
            if values else None

    return {"runs": len(runs), "met": met, "required": required,
            "all_targets_met": all(met[name] >= required[name] for name in met),
            "min_median_max": {
                "pipeline_latency_p99_ms": spread([run["pipeline_latency_p99_ms"] for run in runs]),
                "slowest_loop_fraction": spread([run["slowest_loop_fraction"] for run in runs]),
                "dropped_joint_states": spread([run["dropped_joint_states"] for run in runs]),
                "real_time_factor": spread([run["real_time_factor"] for run in runs]),
                "free_motion_error_max_mm": spread([1e3 * run["metrics"]["free_motion_error_max_m"] for run in runs
                                                    if run["metrics"].get("free_motion_error_max_m") is not None]),
                "free_motion_error_rms_mm": spread([1e3 * run["metrics"]["free_motion_error_rms_m"] for run in runs
                                                    if run["metrics"].get("free_motion_error_rms_m") is not None])}}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=REPO / "results" / "bench.json")
    parser.add_argument("--runs", type=int, default=1, help="consecutive default main jobs, summarised")
    parser.add_argument("--runs-dir", type=Path, default=None, help="run folders (default runs/bench-<time>)")
    parser.add_argument("--ticks", type=int, default=20000, help="bench_core ticks")
    parser.add_argument("--lockstep-duration", type=float, default=10.0)
    parser.add_argument("--skip-default", action="store_true", help="skip the default main job")
    parser.add_argument("--skip-lockstep", action="store_true")
    parser.add_argument("--markdown", action="store_true", help="only print --out as markdown tables (no runs)")
    parser.add_argument("--launcher-args", default="", help="more launcher options for the default and lockstep "
                                                            "runs, one string (an A/B: e.g. \"--group a,b\")")
    parser.add_argument("--stress", default=None, metavar="LEVELS",
                        help="the starvation harness at these CPU levels, %% of one CPU (e.g. 150,100,70,50); "
                             "--runs single-host runs per level")
    parser.add_argument("--two-stations-runs", type=int, default=0, help="--stress: two-station runs per level")
    parser.add_argument("--stress-node", default=None, help="--stress: throttle this node alone (e.g. replica)")
    parser.add_argument("--spare", default=None,
                        help="--stress: leave this node out of the whole graph's quota (the recorder: the bag then "
                             "holds the whole run)")
    parser.add_argument("--hogs", type=int, default=0, help="--stress: busy processes competing (niceness 0)")
    parser.add_argument("--hog-cpus", default="", help="--stress: pin the hogs to these CPUs, e.g. 0")
    parser.add_argument("--period-us", type=int, default=None, help="--stress: the quota's CFS period [us]")
    parser.add_argument("--graph-lock", type=Path, default=None,
                        help="--stress: flock this file around each run (e.g. /tmp/fic_graph.lock)")
    parser.add_argument("--versus", nargs="+", default=None, metavar="NAME=DIR[:ARGS]",
                        help="whole main jobs of these checkouts or launcher options, --runs rounds taken in turn "
                             "(bench_versus.py; DIR . is this checkout); results/bench_versus.json unless --out")
    parser.add_argument("--stop-at", default=None, metavar="HH:MM",
                        help="--stress: start no run at or after this local time (a rerun resumes)")
    args = parser.parse_args(argv)
    launcher_args = shlex.split(args.launcher_args)
    if args.versus is not None:
        from fic_teleop_experiments.tools import bench_versus

        try:
            arms = [bench_versus.parse_arm(text, REPO) for text in args.versus]
        except argparse.ArgumentTypeError as exc:
            parser.error(str(exc))
        out = args.out if args.out != parser.get_default("out") else REPO / "results" / "bench_versus.json"
        runs_dir = args.runs_dir or REPO / "runs" / f"bench-versus-{datetime.now().strftime('%Y%m%d-%H%M%S')}"
        return bench_versus.versus(arms, args.runs, runs_dir, out)
    if args.stress is not None:
        out = args.out if args.out != parser.get_default("out") else REPO / "results" / "stress.json"
        if args.markdown:
            print(stress_markdown(json.loads(out.read_text())))
            return 0
        return stress_bench(args, launcher_args, out)
    if args.markdown:
        print(markdown(json.loads(args.out.read_text())))
        return 0
    if args.runs < 1:
        parser.error("--runs must be at least 1")
    runs_dir = args.runs_dir or REPO / "runs" / f"bench-{datetime.now().strftime('%Y%m%d-%H%M%S')}"
    runs_dir.mkdir(parents=True, exist_ok=True)
    result: dict = {"generated": datetime.now().isoformat(timespec="seconds"),
                    "machine": {"cpus": os.cpu_count(), "load_average_at_start": list(os.getloadavg())},
                    "commands": {}, "launcher_args": launcher_args}

    print("[bench] replica tick compute (fic_teleop_experiments.tools.bench_core) ...", flush=True)
    core = bench_core(args.ticks, runs_dir)
    result["replica_tick_us"] = {key: core["replica"].get(key) for key in ("median_us", "p99_us", "max_us", "count")}
    cpu_only = core.get("replica (CPU time)") or {}
    result["replica_tick_cpu_time_us"] = {key: cpu_only.get(key) for key in ("median_us",
                                                                             "p99_us")} if cpu_only else None
    result["commands"]["replica_tick"] = f"python -m fic_teleop_experiments.tools.bench_core --ticks {args.ticks}"

    if not args.skip_default:
        result["default_runs"] = []
        for index in range(args.runs):
            name = "default" if args.runs == 1 else f"default-{index + 1}"
            print(f"[bench] default main job {index + 1}/{args.runs} ...", flush=True)
            result["default_runs"].append(default_run(runs_dir / name, runs_dir / f"{name}.log", launcher_args))
        result["default_main_job"] = result["default_runs"][0]
        result["default_summary"] = summary(result["default_runs"])
        result["commands"]["default_main_job"] = "time scripts/run_teleop.sh"

    if not args.skip_lockstep:
        run_dir = runs_dir / "lockstep"
        command = [sys.executable, "-m", "fic_teleop_bringup.teleop_launcher", "--time-mode", "lockstep",
                   "--duration", f"{args.lockstep_duration:g}", "--no-report", "--no-video", "--out", str(run_dir),
                   *launcher_args]
        print(f"[bench] lockstep graph: {' '.join(command[1:])} ...", flush=True)
        code, wall, nodes = run_sampled(command, runs_dir / "lockstep.log")
        from fic_teleop_experiments.runner import report_metrics

        metrics = report_metrics(run_dir / "bag") if (run_dir / "bag").exists() else {}
        text = (runs_dir / "lockstep.log").read_text(errors="replace")
        stopped = re.search(r"graph stopped after ([0-9.]+) s wall, ([0-9.]+) s simulated", text)
        rtf = metrics.get("real_time_factor")
        result["lockstep"] = {
            "exit_code": code, "wall_s_incl_start_stop": round(wall, 1),
            "simulated_s": float(stopped.group(2)) if stopped else None,
            "real_time_factor": rtf, "steps_per_s": round(rtf * 1000.0, 1) if rtf else None,
            "nodes": nodes, "load_average_after": list(os.getloadavg())}
        result["commands"]["lockstep"] = (f"scripts/run_teleop.sh --time-mode lockstep --duration "
                                          f"{args.lockstep_duration:g} --no-report --no-video")

    write_json(args.out, result)
    print_table(result)
    print(f"[bench] {args.out}")
    return 0


def stress_bench(args: argparse.Namespace, launcher_args: list[str], out: Path) -> int:
    """--stress: the harness's runs, level by level in turn (module docstring), summarised per level."""
    from fic_teleop_experiments.tools.stress import (
        DEFAULT_PERIOD_US,
        DEFAULT_SHARES,
        StressError,
        level_summary,
        parse_levels,
        resumed,
        run_figures,
        stressed_run,
    )

    levels = parse_levels(args.stress)

    def label(level: float | None) -> str:
        return "none" if level is None else f"{level:g}"
    runs_dir = args.runs_dir or REPO / "runs" / f"stress-{datetime.now().strftime('%Y%m%d-%H%M%S')}"
    cpus = [int(c) for c in args.hog_cpus.split(",") if c.strip()] or None
    period = args.period_us or DEFAULT_PERIOD_US
    result: dict = {"generated": datetime.now().isoformat(timespec="seconds"), "levels_percent_of_one_cpu": levels,
                    "node": args.stress_node, "spare": args.spare, "hogs": args.hogs, "hog_cpus": cpus,
                    "period_us": period,
                    "shares": DEFAULT_SHARES, "launcher_args": launcher_args, "runs_dir": str(runs_dir),
                    "machine": {"cpus": os.cpu_count(), "load_average_at_start": list(os.getloadavg())},
                    "command": "scripts/bench.sh " + " ".join(shlex.quote(a) for a in sys.argv[1:]), "runs": []}
    try:   # a rerun with the same settings keeps the finished runs and makes only the missing ones
        result = resumed(out, result)
    except StressError as error:
        print(f"[bench] refused: {error}", file=sys.stderr)
        return 2
    runs_dir = Path(result.get("runs_dir") or runs_dir)
    runs_dir.mkdir(parents=True, exist_ok=True)
    finished = {row["name"] for row in result["runs"]}
    plan = [(kind, index) for index in range(max(args.runs, args.two_stations_runs))
            for kind in ("single", "two_stations")
            if index < (args.runs if kind == "single" else args.two_stations_runs)]
    for kind, index, level in [(kind, index, level) for kind, index in plan for level in levels]:
        name = f"{kind}-{label(level)}-{index + 1}"
        if name in finished:
            continue
        if args.stop_at and datetime.now().strftime("%H:%M") >= args.stop_at:
            print(f"[bench] {args.stop_at} reached: no new run (a rerun resumes)", flush=True)
            break
        if (runs_dir / name).exists():   # a run interrupted before its row was written: made again
            shutil.rmtree(runs_dir / name)
        extra = ["--two-stations"] if kind == "two_stations" else []
        print(f"[bench] stress {name} ...", flush=True)
        cpu_before = psutil.cpu_times()
        try:
            run = stressed_run([*launcher_args, *extra, "--no-video"], runs_dir / name,
                               level, node=args.stress_node, spare=args.spare, hogs=args.hogs,
                               hog_cpus=cpus, period_us=period, log=runs_dir / f"{name}.log",
                               graph_lock=args.graph_lock)
        except StressError as error:
            print(f"[bench] refused: {error}", file=sys.stderr)
            return 2
        row = {"name": name, "kind": kind, "level_percent": level, **run,
               **run_figures(runs_dir / name, run["exit_code"]),
               "load_average_after": list(os.getloadavg()),
               "machine_cpu_during_run": machine_shares(cpu_before, psutil.cpu_times())}
        result["runs"].append(row)
        print(f"[bench]   exit {row['exit_code']}, starved {row['flagged_starved']}, RTF "
              f"{row['real_time_factor']}, holds {row['holds']}, violations {row['limit_violations']}, "
              f"runaway {row['runaway']} {row['reasons'] or ''}"
              + (f", lost tracking ({row['lost_tracking_reason']})" if row.get("lost_tracking") else ""),
              flush=True)
        result["levels"] = {f"{k} {label(lv)}": level_summary([r for r in result["runs"]
                                                              if r["kind"] == k and r["level_percent"] == lv])
                            for k in ("single", "two_stations") for lv in levels
                            if any(r["kind"] == k for r in result["runs"])}
        result["machine"]["load_average_at_end"] = list(os.getloadavg())
        write_json(out, result)   # after every run: an interrupted bench keeps what it measured
    print(stress_markdown(result))
    print(f"[bench] {out}")
    return 0


def stress_markdown(result: dict) -> str:
    """The per-level table of a --stress bench."""
    machine = result["machine"]
    load = ", ".join(f"{x:.1f}" for x in machine["load_average_at_start"])
    if machine.get("load_average_at_end"):
        load += " at start, " + ", ".join(f"{x:.1f}" for x in machine["load_average_at_end"]) + " at end"
    throttled = f"node {result['node']}" if result.get("node") else (
        f"the whole graph but the {result['spare']}" if result.get("spare") else "the whole graph")
    hogs = f", {result['hogs']} CPU hogs" if result.get("hogs") else ""
    lines = [f"Stress bench {result['generated']}: `{result['command']}`; quota period {result['period_us']} us on "
             f"{throttled}{hogs}; load average {load} ({machine['cpus']} cores).", "",
             "| runs | level (% of one CPU) | n | runaways | lost tracking | with violations (held) | with holds "
             "| flagged starved | exit codes | RTF min / med / max | slowest loop min / med / max | bag's share of the "
             "run min / med "
             "| error max mm min / med / max | error RMS mm med | max joint speed / datasheet |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]

    def show(values, index=None, spec=".3g"):
        if not values:
            return "n/a"
        return format(values[index], spec) if index is not None else " / ".join(format(v, spec) for v in values)

    for key, level in (result.get("levels") or {}).items():
        kind, _, percent = key.partition(" ")
        lines.append(f"| {kind.replace('_', '-')} | {percent} | {level['runs']} | {level['runaways']} | "
                     f"{_known(level.get('lost_tracking'))} | "
                     f"{level['runs_with_violations']} ({_known(level['violations_where_held'])}) | "
                     f"{_known(level['runs_with_holds'])} | "
                     f"{level['flagged_starved']} | {', '.join(map(str, level['exit_codes']))} | "
                     f"{show(level['real_time_factor'])} | {show(level['slowest_loop_fraction'])} | "
                     f"{show((level.get('recorded_fraction') or [])[:2])} | "
                     f"{show(level['free_motion_error_max_mm'])} | {show(level['free_motion_error_rms_mm'], 1)} | "
                     f"{show(level['max_joint_speed_ratio'], 2)} |")
    return "\n".join(lines)


def _known(value) -> str:
    return "n/a" if value is None else str(value)


def markdown(result: dict) -> str:
    tick = result["replica_tick_us"]
    default, lock = result.get("default_main_job") or {}, result.get("lockstep") or {}
    late = default.get("realtime_step_lateness") or {}
    lines = [f"### Benchmarks ({result['generated']}, load average at start "
             f"{', '.join(f'{x:.1f}' for x in result['machine']['load_average_at_start'])} on "
             f"{result['machine']['cpus']} cores)", "",
             "| figure | value | command |", "|---|---|---|",
             f"| replica tick compute, median / p99 | {tick['median_us']:.0f} / {tick['p99_us']:.0f} us | "
             f"`{result['commands'].get('replica_tick')}` |"]
    cpu = result.get("replica_tick_cpu_time_us") or {}
    if cpu.get("median_us") is not None:
        lines.append(f"| replica tick, thread CPU time (leaves out time given to other processes), median / p99 | "
                     f"{cpu['median_us']:.0f} / {cpu['p99_us']:.0f} us | same |")
    if default:
        lines += [f"| default main job, wall time (setup check, 30 s run, stop, report) | {default['wall_s']:.0f} s | "
                  f"`time scripts/run_teleop.sh` |",
                  f"| pipeline latency, median / p99 (default run) | {default['pipeline_latency_p50_ms']:.2f} / "
                  f"{default['pipeline_latency_p99_ms']:.2f} ms | same run's metrics.json |",
                  f"| real-time factor (default run, realtime) | {default['real_time_factor']:.3f} | same |",
                  f"| machine CPU during that run (% of both cores) | "
                  f"{', '.join(f'{k[:-8]} {v}' for k, v in (default.get('machine_cpu_during_run') or {}).items())} | "
                  f"psutil.cpu_times() before and after |",
                  f"| realtime step lateness p50 / p99 / max (robot_sim, last 10 s) | "
                  f"{late.get('lateness_p50_ms', float('nan')):.2f} / {late.get('lateness_p99_ms', float('nan')):.2f} "
                  "/ "
                  f"{late.get('lateness_max_ms', float('nan')):.1f} ms; achieved "
                  f"{late.get('achieved_rate_hz', float('nan')):.0f} Hz"
                  f" | same run's bag (/diagnostics) |",
                  f"| /sim/step_lateness (worst step per 0.1 s), median / p99 | "
                  f"{late.get('step_lateness_topic_worst_per_100ms_median_ms', float('nan')):.2f} / "
                  f"{late.get('step_lateness_topic_worst_per_100ms_p99_ms', float('nan')):.2f} ms | same run's bag |"]
    if lock:
        lines.append(f"| lockstep physics steps per second, whole graph answering | {lock['steps_per_s']} (RTF "
                     f"{lock['real_time_factor']:.3f}) | `{result['commands'].get('lockstep')}` |")
    for label, block in (("realtime default run", default), ("lockstep run", lock)):
        if block.get("nodes"):
            lines += ["", f"Per node, {label} (CPU: CPU seconds per wall second, 100 % = one core; RSS peak):", "",
                      "| node | CPU % | peak RSS MB |", "|---|---|---|"]
            lines += [f"| {name} | {row['cpu_percent_of_one_core']} | {row['peak_rss_mb']} |"
                      for name, row in block["nodes"].items() if name != MAIN_JOB]
    budget = default.get("cpu_budget")
    if budget:
        main_job = default["nodes"].get(MAIN_JOB, {})
        lines += ["", f"CPU budget of the default run: the main job {main_job.get('cpu_s')} CPU-s in all (user "
                      f"{main_job.get('user_s')}, system {main_job.get('system_s')}) for {budget['simulated_s']} s "
                      "simulated:", "", "| process | CPU-s | CPU-s per simulated s | published / s | received / s |",
                  "|---|---|---|---|---|"]
        lines += [f"| {name} | {row['cpu_s']} | {row['cpu_s_per_simulated_s']} | {row.get('published_per_s', '')} | "
                  f"{row.get('received_per_s', '')} |" for name, row in sorted(
                      budget["processes"].items(), key=lambda item: -item[1]["cpu_s"]) if name != MAIN_JOB]
    return "\n".join(lines)


def print_table(result: dict) -> None:
    tick = result["replica_tick_us"]
    print(f"\nreplica tick compute          median {tick['median_us']:.1f} us, p99 {tick['p99_us']:.1f} us")
    default = result.get("default_main_job")
    if default:
        print(f"default main job              {default['wall_s']:.1f} s wall (exit {default['exit_code']})")
        print(f"pipeline latency              median {default['pipeline_latency_p50_ms']} ms, "
              f"p99 {default['pipeline_latency_p99_ms']} ms")
        print(f"real-time factor (realtime)   {default['real_time_factor']}")
        print(f"machine CPU during the run    {default.get('machine_cpu_during_run')}")
        print(f"realtime step lateness        {default['realtime_step_lateness']}")
        for name, row in (default.get("loop_rates") or {}).items():
            print(f"  loop {name:<22} {row['achieved_hz']:>7.1f} of {row['nominal_hz']:g} Hz ({row['fraction']:.1%})")
    runs = result.get("default_runs") or []
    if len(runs) > 1:
        print(f"\n{len(runs)} default runs   p99 ms   slowest loop   lost states   RTF    error max / RMS mm")
        for index, run in enumerate(runs):
            metrics = run["metrics"]
            print(f"  run {index + 1:<10} {run['pipeline_latency_p99_ms'] or float('nan'):>7.1f}   "
                  f"{run['slowest_loop_fraction'] or float('nan'):>11.1%}   {run['dropped_joint_states']!s:>11}   "
                  f"{run['real_time_factor'] or float('nan'):.3f}   "
                  f"{1e3 * (metrics.get('free_motion_error_max_m') or float('nan')):.1f} / "
                  f"{1e3 * (metrics.get('free_motion_error_rms_m') or float('nan')):.1f}")
        totals = result["default_summary"]
        for name, count in totals["met"].items():
            print(f"  target {name:<34} met in {count} of {len(runs)} (needs {totals['required'][name]})")
    lock = result.get("lockstep")
    if lock:
        print(f"lockstep                      {lock['steps_per_s']} steps/s (RTF {lock['real_time_factor']})")
    for label, block in (("realtime", default), ("lockstep", lock)):
        if block and block.get("nodes"):
            print(f"\nper node ({label})            CPU % of one core   peak RSS MB")
            for name, row in block["nodes"].items():
                if name != MAIN_JOB:
                    print(f"  {name:<26} {row['cpu_percent_of_one_core']!s:>10}   {row['peak_rss_mb']:>10}")
    for index, run in enumerate(runs or ([default] if default else [])):
        print_budget(run, f"run {index + 1}")


def print_budget(run: dict, label: str) -> None:
    """The CPU budget of one default run (cpu_budget): per process CPU-s, per simulated second, messages a second."""
    budget = run.get("cpu_budget")
    if not budget:
        return
    main_job = run["nodes"].get(MAIN_JOB, {})
    print(f"\nCPU budget, {label}: main job {main_job.get('cpu_s')} CPU-s (user {main_job.get('user_s')}, system "
          f"{main_job.get('system_s')}) for {budget['simulated_s']} s simulated")
    print(f"  {'process':<34} {'CPU-s':>7} {'CPU-s/sim s':>11} {'published/s':>11} {'received/s':>10}")
    for name, row in sorted(budget["processes"].items(), key=lambda item: -item[1]["cpu_s"]):
        if name == MAIN_JOB:
            continue
        print(f"  {name:<34} {row['cpu_s']:>7} {row['cpu_s_per_simulated_s']!s:>11} "
              f"{row.get('published_per_s', ''):>11} {row.get('received_per_s', ''):>10}")
    if budget.get("topics_not_in_the_bag"):
        print("  (messages of topics the bag does not hold are not counted: "
              f"{', '.join(budget['topics_not_in_the_bag'])})")


if __name__ == "__main__":
    sys.exit(main())
