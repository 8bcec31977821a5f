"""Watch the graph's control processes from outside and record what they are doing when one stops ticking.

A realtime replica ticks on every joint state (500 Hz), so its main thread goes to sleep and wakes several hundred
times a second: its voluntary context switches (``/proc/<pid>/task/<tid>/status``) rise that fast, and a thread
that is busy catching up runs (its run time in ``schedstat`` rises). When neither rises for longer than
``--stall-ms``, this watcher records, every sample while the stall lasts, each thread's
scheduler state, kernel wait channel and kernel stack (``/proc/.../stack``, root only), and the machine's counters
that could explain a pause: CPU steal, major page faults, file refaults, the pressure-stall totals, the run queue,
the CPU time of the kernel's memory-monitoring thread (kdamond). The watcher itself runs at a realtime priority
(SCHED_FIFO) and records its own sampling gaps: a pause it sees too did not come from the processes it watches
(a pause of the virtual machine, or the kernel holding both CPUs).

    python -m fic_teleop_experiments.tools.stall_watch --out runs/x/stalls.jsonl [--names replica_node robot_node] [--stall-ms 100]

Runs until SIGINT/SIGTERM; one JSON line per event (``self_gap``, ``stall_start``, ``stall_sample``, ``stall_end``).
The tick-gap study in docs/RESULTS.md ("Starvation") was made with it.
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import time
from pathlib import Path

CLK_TCK = os.sysconf("SC_CLK_TCK")


def _read(path: str) -> str:
    try:
        with open(path, encoding="utf-8", errors="replace") as file:
            return file.read()
    except OSError:
        return ""


def find_processes(names: list[str]) -> dict[int, str]:
    """pid -> comm of the live processes whose comm is one of ``names``."""
    found = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            comm = _read(f"/proc/{entry}/comm").strip()
            if comm in names:
                found[int(entry)] = comm
    return found


def progress(pid: int) -> tuple[int, int, int] | None:
    """The main thread's (voluntary switches, run time [ns], time waited on a run queue [ns])."""
    switches = next((int(line.split()[1]) for line in _read(f"/proc/{pid}/task/{pid}/status").splitlines()
                     if line.startswith("voluntary_ctxt_switches")), None)
    schedstat = _read(f"/proc/{pid}/task/{pid}/schedstat").split()
    if switches is None or len(schedstat) < 2:
        return None
    return switches, int(schedstat[0]), int(schedstat[1])


def thread_states(pid: int, stacks: bool) -> list[dict]:
    """Every thread of ``pid``: name, state, wait channel, CPU ticks, and (``stacks``) its kernel stack."""
    rows = []
    try:
        tids = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return rows
    for tid in tids:
        base = f"/proc/{pid}/task/{tid}"
        stat = _read(f"{base}/stat")
        if not stat:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        row = {"tid": int(tid), "comm": _read(f"{base}/comm").strip(), "state": fields[0],
               "wchan": _read(f"{base}/wchan").strip(), "cpu_ticks": int(fields[11]) + int(fields[12]),
               "processor": int(fields[36])}
        if stacks and fields[0] != "S":
            row["stack"] = [line.split(" ", 1)[-1] for line in _read(f"{base}/stack").splitlines()][:12]
        rows.append(row)
    return rows


def machine_counters() -> dict:
    cpu = _read("/proc/stat").splitlines()[0].split()[1:]
    vmstat = dict(line.split() for line in _read("/proc/vmstat").splitlines() if line)
    kdamond = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit() and _read(f"/proc/{entry}/comm").startswith("kdamond"):
            fields = _read(f"/proc/{entry}/stat").rsplit(")", 1)[1].split()
            kdamond[entry] = {"state": fields[0], "cpu_ticks": int(fields[11]) + int(fields[12])}
    pressure = {kind: _read(f"/proc/pressure/{kind}").split("\n")[0].split()[-1] for kind in ("cpu", "memory", "io")}
    return {"steal_ticks": int(cpu[7]), "iowait_ticks": int(cpu[4]), "pgmajfault": int(vmstat.get("pgmajfault", 0)),
            "workingset_refault_file": int(vmstat.get("workingset_refault_file", 0)),
            "procs_running": next((int(line.split()[1]) for line in _read("/proc/stat").splitlines()
                                   if line.startswith("procs_running")), None),
            "pressure_total_us": pressure, "kdamond": kdamond}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--names", nargs="+", default=["replica_node", "robot_node"])
    parser.add_argument("--stall-ms", type=float, default=100.0, help="no voluntary switch this long: a stall")
    parser.add_argument("--period-ms", type=float, default=5.0)
    parser.add_argument("--self-gap-ms", type=float, default=30.0, help="the watcher's own sampling gaps recorded")
    parser.add_argument("--priority", type=int, default=60, help="SCHED_FIFO priority (0: stay SCHED_OTHER)")
    args = parser.parse_args()
    if args.priority:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(args.priority))
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    out = open(args.out, "a", encoding="utf-8")

    def write(kind: str, **fields) -> None:
        out.write(json.dumps({"event": kind, "wall": round(time.time(), 4), **fields}) + "\n")
        out.flush()

    period, stall = args.period_ms * 1e-3, args.stall_ms * 1e-3
    watched: dict[int, dict] = {}
    last_scan = last_sample = time.monotonic()
    while not stop:
        time.sleep(period)
        now = time.monotonic()
        if now - last_sample > args.self_gap_ms * 1e-3:
            write("self_gap", gap_ms=round((now - last_sample) * 1e3, 1), machine=machine_counters())
        last_sample = now
        if now - last_scan > 1.0 or not watched:
            live = find_processes(args.names)
            for pid in list(watched):
                if pid not in live:
                    del watched[pid]
            for pid, comm in live.items():
                watched.setdefault(pid, {"comm": comm, "progress": progress(pid), "since": now, "stalled": False})
            last_scan = now
        for pid, entry in watched.items():
            current = progress(pid)
            if current is None or entry["progress"] is None:
                entry["progress"] = current
                continue
            if current[:2] != entry["progress"][:2]:
                if entry["stalled"]:
                    # run-queue wait across the stall: a thread that was runnable but not run (CPU, quota, VM)
                    write("stall_end", pid=pid, comm=entry["comm"], stall_ms=round((now - entry["since"]) * 1e3, 1),
                          run_queue_wait_ms=round((current[2] - entry["progress"][2]) * 1e-6, 1),
                          machine=machine_counters())
                entry.update(progress=current, since=now, stalled=False)
            elif now - entry["since"] > stall:
                if not entry["stalled"]:
                    entry["stalled"] = True
                    write("stall_start", pid=pid, comm=entry["comm"], after_ms=round((now - entry["since"]) * 1e3, 1),
                          machine=machine_counters(), threads=thread_states(pid, True))
                else:
                    write("stall_sample", pid=pid, comm=entry["comm"], ms=round((now - entry["since"]) * 1e3, 1),
                          threads=thread_states(pid, True))
    out.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
