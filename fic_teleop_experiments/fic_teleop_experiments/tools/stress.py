"""The starvation harness: the graph (or one node of it) given a stated share of the CPU, and what the arm did.

A run that starves on a loaded machine starves by accident, at an unknown level. Here the CPU a run gets is set:

- a CPU quota, as root, through the kernel's CFS bandwidth control: a cgroup whose tasks together run at most
  ``level`` % of one CPU in each ``period`` (cgroup v1: ``cpu.cfs_quota_us`` / ``cpu.cfs_period_us`` under the
  ``cpu`` hierarchy; v2: ``cpu.max``). The whole graph: the launcher joins the cgroup before it starts, and every
  node it starts (and, in a two-station run, both stations' nodes: ``ip netns exec`` keeps the cgroup) is in it.
  One node (``node``): the launcher runs free and that node's process joins the cgroup as soon as it appears;
  the whole graph but one (``spare``, the recorder): that node's process leaves the cgroup as soon as it appears,
  so that the bag, the harness's instrument, holds the whole run.
  The default period, 20 ms, is short enough that a throttled graph is stopped for at most a few ticks of the
  replica's 2 ms at a time at the lower levels (a 100 ms period let it run 50 ms and stop 50 ms at 50 %).
  A quota is a ceiling only: beside other busy sessions (each one entity of weight 1024 under the kernel's
  autogroup scheduling) a group of the default weight got less than its level. So the group also gets a high
  weight (``shares``, default 8192: v1 ``cpu.shares``, v2 ``cpu.weight`` scaled alike), and under competing load
  the graph gets its quota, so that the level is the share the graph had;
- optional CPU hogs: busy processes pinned to given CPUs (``sched_setaffinity``), outside the cgroup, at niceness 0,
  competing with whatever else runs there.

Then the run's record is read back (``run_figures``): whether the launcher flagged it as starved (its timing.json
and exit code 6, fic_teleop_bringup/launch_timing.py), the replica's holds on its own loop's bounds, the real-time
factor, the free-motion error, the limit violations, and whether the arm ran away. A runaway is any of: a joint faster
than its datasheet limit, a kinetic energy above that of the arm's mass moving at the datasheet's 1.7 m/s TCP speed,
or a trip of the simulated robot's velocity reflex (from its log, which a starved recorder cannot lose); the
figures behind each are kept. A free-motion error above 4 x_b is reported as lost tracking, beside it: a held arm
stays put while its set point moves on.

    scripts/stress.sh 70 [--node replica] [--hogs 1 --hog-cpus 0] -- --duration 20      # one run at 70 %
    scripts/bench.sh --stress 150,100,70,50 --runs 20                                 # the table per level
"""
from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from fic_teleop_runtime.workspace import working_folder

REPO = working_folder()   # runs/ and results/ (FIC_TELEOP_ROOT, else the current folder)
LAUNCHER = [sys.executable, "-m", "fic_teleop_bringup.teleop_launcher"]   # what scripts/run_teleop.sh runs
DEFAULT_PERIOD_US = 20_000
DEFAULT_SHARES = 8192               # the quota group's CPU weight (v1 cpu.shares; 1024 is a niceness-0 session's)
RUNAWAY_ERROR_BOUNDS = 4.0          # free-motion error above this many x_b
EXIT_STARVED = 6                    # fic_teleop_bringup/launch_supervision.py (not imported here)
V1_ROOT = Path("/sys/fs/cgroup/cpu")


class StressError(RuntimeError):
    """The harness cannot set what it was asked for (no root, no cpu controller, a bad level)."""


class CpuQuota:
    """A cgroup holding its tasks to ``level_percent`` % of one CPU; removed (tasks back in the parent) on close."""

    def __init__(self, level_percent: float, period_us: int = DEFAULT_PERIOD_US, name: str | None = None,
                 shares: int = DEFAULT_SHARES) -> None:
        if not (np.isfinite(level_percent) and 1.0 <= level_percent <= 100.0 * (os.cpu_count() or 1)):
            raise StressError(f"a CPU level must be in [1, {100 * (os.cpu_count() or 1)}] % of one CPU, "
                              f"got {level_percent}")
        if not 1000 <= period_us <= 1_000_000:
            raise StressError(f"the quota period must be in [1000, 1000000] us, got {period_us}")
        if not 2 <= shares <= 262_144:
            raise StressError(f"the quota group's CPU shares must be in [2, 262144], got {shares}")
        self.shares = int(shares)
        self.level_percent, self.period_us = float(level_percent), int(period_us)
        self.quota_us = max(1000, round(self.level_percent / 100.0 * self.period_us))
        name = name or f"fic_stress_{os.getpid()}_{int(time.monotonic() * 1e3)}"
        self.version, self.parent = _cpu_hierarchy()
        self.path = self.parent / name
        try:
            self.path.mkdir()
            if self.version == 1:
                (self.path / "cpu.cfs_period_us").write_text(str(self.period_us))
                (self.path / "cpu.cfs_quota_us").write_text(str(self.quota_us))
                (self.path / "cpu.shares").write_text(str(self.shares))
            else:
                (self.path / "cpu.max").write_text(f"{self.quota_us} {self.period_us}")
                # v2's weight is 100 where v1's shares are 1024, in [1, 10000]
                (self.path / "cpu.weight").write_text(str(min(10_000, max(1, round(self.shares * 100 / 1024)))))
        except OSError as error:
            self.close()
            raise StressError(f"cannot set a CPU quota in {self.path}: {error.strerror or error}") from None

    def join(self, pid: int) -> None:
        """Move process ``pid`` (all its threads) into the quota; its children from now on are born in it."""
        (self.path / "cgroup.procs").write_text(str(pid))

    def leave(self, pid: int) -> None:
        """Move process ``pid`` back into the parent group (out of the quota)."""
        (self.parent / "cgroup.procs").write_text(str(pid))

    def members(self) -> list[int]:
        try:
            return [int(line) for line in (self.path / "cgroup.procs").read_text().split()]
        except OSError:
            return []

    def throttled(self) -> dict[str, int]:
        """The kernel's count of periods and of throttled ones (cpu.stat)."""
        try:
            pairs = [line.split() for line in (self.path / "cpu.stat").read_text().splitlines()]
        except OSError:
            return {}
        return {key: int(value) for key, value in pairs if key in ("nr_periods", "nr_throttled",
                                                                    "throttled_time", "throttled_usec")}

    def close(self) -> None:
        if not self.path.exists():
            return
        for pid in self.members():   # anything left (a stray node) back into the parent, then the group goes
            try:
                (self.parent / "cgroup.procs").write_text(str(pid))
            except OSError:
                pass
        try:
            self.path.rmdir()
        except OSError:
            pass

    def __enter__(self) -> "CpuQuota":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _cpu_hierarchy() -> tuple[int, Path]:
    """(1, the v1 cpu hierarchy) or (2, a v2 group with the cpu controller); StressError if neither."""
    if os.geteuid() != 0:
        raise StressError("a CPU quota needs root (cgroups)")
    if (V1_ROOT / "cpu.cfs_quota_us").exists():
        return 1, V1_ROOT
    for root in (Path("/sys/fs/cgroup"), Path("/sys/fs/cgroup/unified")):
        controllers = root / "cgroup.subtree_control"
        if controllers.exists() and "cpu" in controllers.read_text().split():
            return 2, root
    raise StressError("no cgroup cpu controller here (neither v1 cpu.cfs_quota_us nor v2 cpu.max)")


def _spin(cpu: int | None) -> None:
    if cpu is not None:
        os.sched_setaffinity(0, {cpu})
    while True:
        pass


class CpuHogs:
    """``count`` busy processes, the i-th pinned to ``cpus[i % len(cpus)]`` (none: unpinned); stopped on close."""

    def __init__(self, count: int, cpus: list[int] | None = None) -> None:
        context = multiprocessing.get_context("fork")
        self.processes = [context.Process(target=_spin, args=(cpus[i % len(cpus)] if cpus else None,), daemon=True)
                          for i in range(count)]
        for process in self.processes:
            process.start()

    def close(self) -> None:
        for process in self.processes:
            process.terminate()
        for process in self.processes:
            process.join(timeout=5)

    def __enter__(self) -> "CpuHogs":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _node_processes(root: int, node: str) -> list[int]:
    """pids under ``root`` whose command line names ``node`` (``__node:=node``, alone or in a group)."""
    import psutil

    found = []
    try:
        children = psutil.Process(root).children(recursive=True)
    except psutil.NoSuchProcess:
        return found
    for child in children:
        try:
            names = [item.split("=", 1)[1] for item in child.cmdline() if item.startswith("__node:=")]
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            continue
        if any(node in name.split("+") for name in names) or node in names:
            found.append(child.pid)
    return found


def stressed_run(launcher_args: list[str], out: Path, level_percent: float | None, *, node: str | None = None,
                 spare: str | None = None, hogs: int = 0, hog_cpus: list[int] | None = None,
                 period_us: int = DEFAULT_PERIOD_US, log: Path | None = None,
                 env: dict[str, str] | None = None, graph_lock: Path | None = None,
                 shares: int = DEFAULT_SHARES) -> dict:
    """One launcher run at ``level_percent`` % of one CPU (None: no quota), the whole graph or ``node`` alone, in
    ``env`` (default: this process's environment); returns the launcher's exit code, the wall time and the
    kernel's throttling counts. ``spare``: a node of the whole graph left out of the quota (the recorder: starved
    with the rest, it kept as little as 2 % of a run, and the runaway check then sees only that). ``graph_lock``: a
    file locked (flock, exclusive) for this run alone, so that one graph at a time runs on the machine however many
    runs a bench makes; the wait for it is returned (``lock_wait_s``)."""
    waited = time.monotonic()
    lock_file = _locked(graph_lock) if graph_lock is not None else None
    try:
        result = _stressed_run(launcher_args, out, level_percent, node=node, spare=spare, hogs=hogs,
                               hog_cpus=hog_cpus, period_us=period_us, log=log, env=env, shares=shares,
                               lock_wait_s=round(time.monotonic() - waited, 1))
    finally:
        if lock_file is not None:
            lock_file.close()   # closing the file releases its flock
    return result


def _locked(path: Path):
    """``path`` opened and flock-ed exclusively (blocking): the same lock as ``flock PATH command``."""
    import fcntl

    handle = open(path, "a")
    fcntl.flock(handle.fileno(), fcntl.LOCK_EX)
    return handle


def _stressed_run(launcher_args: list[str], out: Path, level_percent: float | None, *, node: str | None,
                  spare: str | None, hogs: int, hog_cpus: list[int] | None, period_us: int, log: Path | None,
                  env: dict[str, str] | None, shares: int, lock_wait_s: float) -> dict:
    command = [*LAUNCHER, "--out", str(out), *launcher_args]
    quota = CpuQuota(level_percent, period_us, shares=shares) if level_percent is not None else None
    hog = CpuHogs(hogs, hog_cpus) if hogs else None
    started = time.monotonic()
    try:
        log_file = open(log, "w", encoding="utf-8") if log else subprocess.DEVNULL
        try:
            join = (lambda: quota.join(os.getpid())) if quota is not None and node is None else None
            process = subprocess.Popen(command, stdout=log_file, stderr=subprocess.STDOUT, cwd=REPO,
                                       env=dict(os.environ if env is None else env, PYTHONUNBUFFERED="1"),
                                       preexec_fn=join)
            watcher = None
            if quota is not None and node is not None:
                watcher = _NodeWatcher(process.pid, node, quota.join)
                watcher.start()
            elif quota is not None and spare is not None:
                watcher = _NodeWatcher(process.pid, spare, quota.leave)
                watcher.start()
            code = process.wait()
            if watcher is not None:
                watcher.stop()
        finally:
            if log:
                log_file.close()
        throttling = quota.throttled() if quota is not None else {}
    finally:
        if hog is not None:
            hog.close()
        if quota is not None:
            quota.close()
    return {"exit_code": code, "wall_s": round(time.monotonic() - started, 1), "throttling": throttling,
            "node_moved": None if node is None and spare is None else bool(watcher and watcher.joined),
            "shares": shares if quota is not None else None, "lock_wait_s": lock_wait_s}


class _NodeWatcher(threading.Thread):
    """Moves ``node``'s process(es) into the quota, or out of it, as they appear (``move``: CpuQuota.join or
    CpuQuota.leave)."""

    def __init__(self, root: int, node: str, move) -> None:
        super().__init__(daemon=True)
        self.root, self.node, self.move = root, node, move
        self.joined: set[int] = set()
        self._halt = threading.Event()

    def run(self) -> None:
        while not self._halt.is_set():
            for pid in _node_processes(self.root, self.node):
                if pid not in self.joined:
                    try:
                        self.move(pid)
                        self.joined.add(pid)
                    except OSError:
                        pass
            self._halt.wait(0.1)

    def stop(self) -> None:
        self._halt.set()
        self.join(timeout=2)


def runaway_figures(bag: Path, metrics: dict) -> dict:
    """The arm's joint speeds against the datasheet and its kinetic energy against a TCP at 1.7 m/s, from the bag's
    /joint_states (every state), and the free-motion error against 4 x_b (the report's); ``runaway`` and why."""
    from mcap_ros2.reader import read_ros2_messages

    from fic_core.limits import PANDA_TCP_SPEED_LIMIT, PandaLimits
    from fic_core.robot_model import RobotModel

    robot = RobotModel()
    limits = PandaLimits.from_robot(robot)
    speed_limit = limits.joint_velocity_array
    arm_mass = float(sum(inertia.mass for inertia in robot.model.inertias))
    energy_bound = 0.5 * arm_mass * PANDA_TCP_SPEED_LIMIT ** 2
    files = sorted(bag.glob("*.mcap")) if bag.is_dir() else [bag]
    positions, velocities = [], []
    try:
        for file in files:
            for message in read_ros2_messages(str(file), topics=["/joint_states", "/franka/joint_states"]):
                state = message.ros_msg
                if len(state.velocity) >= 7 and len(state.position) >= 7:
                    positions.append(state.position[:7])
                    velocities.append(state.velocity[:7])
    except Exception as error:  # noqa: BLE001 - a torn bag: the figures up to where it could be read
        print(f"[stress] {bag}: read up to a fault ({error})", file=sys.stderr)
    q, qd = np.asarray(positions, dtype=float).reshape(-1, 7), np.asarray(velocities, dtype=float).reshape(-1, 7)
    ratios = np.abs(qd) / speed_limit
    worst_ratio = float(ratios.max()) if len(ratios) else 0.0
    worst_joint = int(np.argmax(ratios.max(axis=0))) + 1 if len(ratios) else None
    worst_energy = 0.0
    # The energy on every 10th state and on every state with a joint above half its datasheet speed.
    for k in np.flatnonzero((np.arange(len(q)) % 10 == 0) | (ratios.max(axis=1, initial=0.0) > 0.5)):
        robot.update(q[k], qd[k])
        worst_energy = max(worst_energy, float(robot.kinetic_energy))
    error_max = metrics.get("free_motion_error_max_m")
    bound = (metrics.get("thresholds") or {}).get("error_bound_m") or 0.05
    reasons = []
    if worst_ratio > 1.0:
        reasons.append(f"joint {worst_joint} at {worst_ratio:.2f} x its datasheet speed")
    if worst_energy > energy_bound:
        reasons.append(f"kinetic energy {worst_energy:.1f} J > {energy_bound:.1f} J")
    # A large error alone is lost tracking, not a runaway: while the replica holds (damping and gravity) the arm
    # stays where it was and the set point moves on (measured: 201-259 mm after 22-40 holds with every joint at most
    # 0.55 of its datasheet speed). It is reported beside the runaway, never folded into it.
    lost_tracking = error_max is not None and error_max > RUNAWAY_ERROR_BOUNDS * bound
    return {"runaway": bool(reasons), "reasons": reasons, "lost_tracking": lost_tracking,
            "lost_tracking_reason": f"free-motion error {error_max * 1e3:.0f} mm > {RUNAWAY_ERROR_BOUNDS:g} x_b"
            if lost_tracking else None, "joint_states": len(q),
            "max_joint_speed_ratio": round(worst_ratio, 3), "fastest_joint": worst_joint,
            "max_kinetic_energy_j": round(worst_energy, 3), "kinetic_energy_bound_j": round(energy_bound, 2)}


def reflex_trips(run_dir: Path) -> list[str]:
    """The simulated robot's velocity-reflex lines in the run's logs (a joint more than 10 % past its datasheet speed
    stops the arm; sim_bridge/robot/velocity_reflex.py). A starved recorder can miss the joint states of that moment
    (measured: a run at 50 % whose bag held 0 of them, its robot's log the trip at 1.10 x joint 6's speed); the
    robot's own log does not, so a trip is a runaway whatever the bag holds."""
    trips = []
    for log in sorted((run_dir / "logs").glob("robot*.log")):
        for line in log.read_text(encoding="utf-8", errors="replace").splitlines():
            if "]: reflex: " in line:
                trips.append(line.split("]: reflex: ", 1)[1][:160])
    return trips


def run_figures(run_dir: Path, exit_code: int) -> dict:
    """One run's row: the launcher's verdict, the replica's holds, RTF, error, violations, runaway."""
    metrics_path = run_dir / "report" / "metrics.json"
    metrics = json.loads(metrics_path.read_text()) if metrics_path.exists() else {}
    timing_path = run_dir / "timing.json"
    timing = json.loads(timing_path.read_text()) if timing_path.exists() else {}
    figures = timing.get("figures") or {}
    bag = run_dir / "bag"
    runaway = runaway_figures(bag, metrics) if bag.exists() else {"runaway": None, "reasons": ["no bag"]}
    trips = reflex_trips(run_dir)
    runaway["reflex_trips"] = len(trips)
    if trips:
        runaway["runaway"] = True
        runaway["reasons"] = [reason for reason in runaway["reasons"] if reason != "no bag"] + \
            [f"the robot's velocity reflex: {trip}" for trip in trips]
    return {"exit_code": exit_code, "flagged_starved": bool(timing.get("starved")),
            "starved_reasons": timing.get("reasons"), "holds": figures.get("loop_holds"),
            "max_state_age_ms": figures.get("max_state_age_ms"),
            "slowest_loop_fraction": figures.get("slowest_loop_fraction"),
            # the share of the run the bag holds: a runaway outside it is not seen (the recorder starves too)
            "recorded_fraction": round(figures["recorded_s"] / figures["simulated_s"], 3)
            if figures.get("recorded_s") is not None and figures.get("simulated_s") else None,
            "real_time_factor": metrics.get("real_time_factor"),
            "limit_violations": metrics.get("limit_violations"),
            "free_motion_error_max_m": metrics.get("free_motion_error_max_m"),
            "free_motion_error_rms_m": metrics.get("free_motion_error_rms_m"),
            "pipeline_latency_p99_ms": metrics.get("pipeline_latency_p99_ms"), **runaway}


def level_summary(rows: list[dict]) -> dict:
    """Per level: runs, runaways, runs that lost tracking, runs with limit violations (and of those, the ones where
    the replica held), holds, RTF and error (min / median / max), how many runs the launcher flagged as starved."""
    def spread(values: list) -> list | None:
        values = [v for v in values if v is not None]
        return [round(float(min(values)), 3), round(float(np.median(values)), 3), round(float(max(values)), 3)] \
            if values else None

    recorded = any(row.get("holds") is not None for row in rows)   # a replica with its loop-health record
    return {"runs": len(rows), "runaways": sum(bool(row.get("runaway")) for row in rows),
            "lost_tracking": sum(bool(row.get("lost_tracking")) for row in rows),
            "runs_with_violations": sum(bool(row.get("limit_violations")) for row in rows),
            "violations_where_held": sum(bool(row.get("limit_violations")) and bool(row.get("holds")) for row in rows)
            if recorded else None,
            "holds": spread([row.get("holds") for row in rows]),
            "runs_with_holds": sum(bool(row.get("holds")) for row in rows) if recorded else None,
            "flagged_starved": sum(bool(row.get("flagged_starved")) for row in rows),
            "exit_codes": sorted({row["exit_code"] for row in rows}),
            "real_time_factor": spread([row.get("real_time_factor") for row in rows]),
            "slowest_loop_fraction": spread([row.get("slowest_loop_fraction") for row in rows]),
            "recorded_fraction": spread([row.get("recorded_fraction") for row in rows]),
            "free_motion_error_max_mm": spread([1e3 * row["free_motion_error_max_m"] for row in rows
                                                if row.get("free_motion_error_max_m") is not None]),
            "free_motion_error_rms_mm": spread([1e3 * row["free_motion_error_rms_m"] for row in rows
                                                if row.get("free_motion_error_rms_m") is not None]),
            "max_joint_speed_ratio": spread([row.get("max_joint_speed_ratio") for row in rows]),
            "max_kinetic_energy_j": spread([row.get("max_kinetic_energy_j") for row in rows])}


#: What makes two benches the same bench: a rerun with these equal resumes the first (``resumed``).
BENCH_SETTINGS = ("levels_percent_of_one_cpu", "node", "spare", "hogs", "hog_cpus", "period_us", "shares",
                  "launcher_args")


def resumed(out: Path, result: dict) -> dict:
    """A bench about to write ``out``: the bench already there if it has the same settings (``BENCH_SETTINGS``),
    its finished runs kept and their run folder reused, so that a rerun with the same arguments runs only the runs
    it lacks; ``result`` itself if ``out`` holds none. A bench of other settings is not overwritten: StressError."""
    if not out.exists():
        return result
    try:
        earlier = json.loads(out.read_text())
    except (OSError, ValueError) as error:
        raise StressError(f"{out} holds no bench that can be resumed ({error}); give another --out") from None
    differing = [key for key in BENCH_SETTINGS if earlier.get(key) != result.get(key)]
    if differing:
        raise StressError(f"{out} holds a bench with other settings ({', '.join(differing)}: "
                          f"{', '.join(repr(earlier.get(key)) for key in differing)}); give another --out")
    return {**earlier, "command": result["command"],
            "resumed": [*earlier.get("resumed", []), result["generated"]]}


def parse_levels(text: str) -> list[float | None]:
    """"150,100,70,50" -> [150.0, 100.0, 70.0, 50.0] (% of one CPU); "none" (no quota) -> None."""
    levels: list[float | None] = []
    for item in text.split(","):
        item = item.strip().rstrip("%")
        levels.append(None if item == "none" else float(item))
    return levels


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="One launcher run at a stated CPU level (scripts/stress.sh).")
    parser.add_argument("level", help="%% of one CPU for the graph (or --node), e.g. 70; 'none': no quota")
    parser.add_argument("--node", default=None, help="throttle this node's process alone (e.g. replica)")
    parser.add_argument("--spare", default=None, help="leave this node out of the whole graph's quota (recorder)")
    parser.add_argument("--hogs", type=int, default=0, help="busy processes competing for the CPU (niceness 0)")
    parser.add_argument("--hog-cpus", default="", help="pin the hogs to these CPUs, e.g. 0 or 0,1")
    parser.add_argument("--period-us", type=int, default=DEFAULT_PERIOD_US, help="the quota's CFS period")
    parser.add_argument("--out", type=Path, default=None, help="run folder (default runs/stress-<level>-<time>)")
    parser.add_argument("--graph-lock", type=Path, default=None,
                        help="flock this file around the run (e.g. /tmp/fic_graph.lock: one graph at a time)")
    parser.add_argument("--shares", type=int, default=DEFAULT_SHARES,
                        help="the quota group's CPU weight (v1 cpu.shares; a niceness-0 session is 1024)")
    argv = list(sys.argv[1:] if argv is None else argv)
    split = argv.index("--") if "--" in argv else len(argv)   # after "--": the launcher's options
    args = parser.parse_args(argv[:split])
    launcher_args = argv[split + 1:]
    level = None if args.level == "none" else float(args.level.rstrip("%"))
    out = args.out or REPO / "runs" / f"stress-{args.level}-{time.strftime('%Y%m%d-%H%M%S')}"
    cpus = [int(c) for c in args.hog_cpus.split(",") if c.strip()] or None
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        result = stressed_run(launcher_args, out, level, node=args.node, spare=args.spare, hogs=args.hogs,
                              hog_cpus=cpus, period_us=args.period_us, log=out.parent / f"{out.name}.log",
                              graph_lock=args.graph_lock, shares=args.shares)
    except StressError as error:
        print(f"[stress] refused: {error}", file=sys.stderr)
        return 2
    row = {"level_percent": level, "node": args.node, "spare": args.spare, "hogs": args.hogs, **result,
           **run_figures(out, result["exit_code"])}
    (out / "stress.json").write_text(json.dumps(row, indent=2) + "\n")
    print(json.dumps(row, indent=2))
    return result["exit_code"]


if __name__ == "__main__":
    sys.exit(main())
