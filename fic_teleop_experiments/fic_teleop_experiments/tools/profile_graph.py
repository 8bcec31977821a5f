"""Where each node process's CPU goes: py-spy samples of every node of one main job, sorted into what they do.

    python -m fic_teleop_experiments.tools.profile_graph [--seconds 20] [--launcher-args "--two-stations"]

Runs the default main job (`scripts/run_teleop.sh --no-video --no-report`, plus ``--launcher-args``), and once its
nodes are up and the operator has started (``--settle`` seconds after the launcher wrote run.json), samples every
node process for ``--seconds``, two ways:
- **CPU by thread**: each thread's user + system time over the window (/proc/PID/task/*/stat), by thread name
  (digits dropped): the Python threads (MainThread, the robot's physics thread, the recorder's) against the DDS
  middleware's own (Fast DDS's receive, event and discovery threads, "dds.*"), which no Python profiler sees;
- **the Python threads' time, by what it does**: py-spy samples taken only while a thread holds the GIL
  (``py-spy record --gil --nonblocking``: the process is never paused). Without --gil, py-spy counts a thread
  waking from a 1 ms sleep as running (measured: a loop of 50 us of work and 1 ms sleeps gave 78 of its 94
  samples in the sleep), so a paced loop or an executor's wait would read as CPU. Held-GIL time is the CPU of
  Python code and of the C code it calls without releasing the GIL (rclpy's conversion to CDR and its DDS write);
  MuJoCo's step releases the GIL and so appears only by its share of the physics thread's CPU above.
- with ``--perf`` (root, Linux perf): **CPU by library**, ``perf record -e cpu-clock`` of each process over the same
  window, by thread and shared object: the interpreter (libpython), the kernel (system calls, scheduling), numpy,
  MuJoCo, Fast DDS. It is the one view of the three that counts CPU exactly, native code included.
Each sample's stack is given to one category, the first of CATEGORIES that a frame matches, walking from the
innermost frame out; numpy frames are passed over, so that numpy's time is its caller's. "executor" is rclpy's C++
executor with the GIL held: taking a message, its conversion to Python, dispatching the callback.
Prints a table per process and writes ``--out`` (JSON).

py-spy reads another process's memory: it needs root, or ptrace permission (kernel.yama.ptrace_scope 0 and the
same user). Why a sampling profiler and not cProfile: it attaches to the running graph without changing its timing
or its code, at 200 samples a second.
"""
from __future__ import annotations

import argparse
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter
from datetime import datetime
from pathlib import Path

from fic_teleop_experiments.runner import write_json
from fic_teleop_experiments.tools.bench import REPO, NodeSampler, run_sampled

#: (category, frame pattern): a frame "function (path:line)" matching the pattern gives the sample to the category.
CATEGORIES: tuple[tuple[str, re.Pattern], ...] = tuple((name, re.compile(pattern)) for name, pattern in (
    ("rclpy publish (to CDR, DDS write)", r"\(rclpy/publisher\.py:"),
    ("rclpy deserialize", r"\(rclpy/serialization\.py:"),
    ("messages (Python objects)", r"\((std_msgs|geometry_msgs|sensor_msgs|builtin_interfaces|diagnostic_msgs|"
                                  r"rosgraph_msgs|fic_teleop_msgs)/msg/"),
    ("rclpy clock, time, logging", r"\(rclpy/(clock|time|logging|impl/rcutils_logger)\.py:"),
    ("physics (MuJoCo step, GIL held)", r"^PandaSimulation\.step "),
    ("Python logging", r"\(logging/"),
    ("fic_core (laws, stations)", r"\(fic_core/"),
    ("executor (C++: wait, take, dispatch)", r"\(fic_teleop_runtime/spin\.py:"),
))
OTHER = "node code and the rest"
_NUMPY = re.compile(r"\(numpy/")


def category(frames: list[str]) -> str:
    """The category of one sample, its frames from the outermost to the innermost (module docstring)."""
    for frame in reversed(frames):
        if _NUMPY.search(frame):
            continue
        for name, pattern in CATEGORIES:
            if pattern.search(frame):
                return name
    return OTHER


def read_raw(path: Path) -> list[tuple[list[str], int]]:
    """py-spy's raw (collapsed-stack) output: one "frame;frame;... count" line a distinct stack. The first frame is
    the thread ("thread (tid): name"), dropped."""
    stacks = []
    for line in path.read_text(encoding="utf-8").splitlines():
        stack, _, count = line.rstrip().rpartition(" ")
        if stack and count.isdigit():
            stacks.append((stack.split(";")[1:], int(count)))
    return stacks


def summarise(stacks: list[tuple[list[str], int]], top: int = 8) -> dict:
    """Samples, the share of each category and the innermost non-numpy functions that take the most."""
    total = sum(count for _, count in stacks)
    shares: Counter = Counter()
    leaves: Counter = Counter()
    for frames, count in stacks:
        shares[category(frames)] += count
        inner = next((frame for frame in reversed(frames) if not _NUMPY.search(frame)), frames[-1] if frames else "?")
        leaves[inner.split(" (")[0] + " (" + inner.split(" (")[-1].split(":")[0] + ")"] += count
    def percent(count: int) -> float:
        return round(100.0 * count / total, 1) if total else 0.0
    return {"samples": total,
            "categories": {name: percent(count) for name, count in shares.most_common()},
            "top_functions": {name: percent(count) for name, count in leaves.most_common(top)}}


def thread_cpu(pid: int) -> dict[str, float]:
    """CPU seconds (user + system) of each thread of ``pid`` so far, summed by thread name with digits dropped
    ("dds.udp.7411" and "dds.udp.7413" are "dds.udp."). Empty when the process is gone."""
    ticks = os.sysconf("SC_CLK_TCK")
    out: dict[str, float] = {}
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            name = re.sub(r"\d+", "", (task / "comm").read_text().strip()) or "?"
            fields = (task / "stat").read_text().rpartition(")")[2].split()
        except OSError:
            continue
        out[name] = out.get(name, 0.0) + (int(fields[11]) + int(fields[12])) / ticks   # utime, stime
    return out


def cpu_difference(before: dict[str, float], after: dict[str, float]) -> dict[str, float]:
    """Per thread name, the CPU seconds spent between two thread_cpu readings (largest first)."""
    spent = {name: round(after[name] - before.get(name, 0.0), 2) for name in after}
    return dict(sorted(((k, v) for k, v in spent.items() if v > 0.0), key=lambda item: -item[1]))


#: Shared objects grouped for the table: (label, pattern of the object's name).
LIBRARIES = tuple((label, re.compile(pattern)) for label, pattern in (
    ("Python interpreter", r"^libpython|^python"), ("kernel", r"kernel|vdso"), ("numpy", r"_multiarray|_umath"),
    ("MuJoCo", r"mujoco|^_functions|^_structs|^_callbacks"), ("Fast DDS and rmw", r"fastrtps|fastdds|fastcdr|^librmw"),
    ("rclpy, rcl, message support", r"rclpy|^librcl|rosidl|__rosidl|_msgs"), ("Pinocchio", r"pinocchio|boost"),
    ("C and C++ runtime", r"^libc\.|^libstdc\+\+|^libm\.|^ld-linux"),
))


def library(shared_object: str) -> str:
    return next((label for label, pattern in LIBRARIES if pattern.search(shared_object)), "other")


def perf_report(data: Path) -> dict[str, dict[str, float]]:
    """``perf report`` of ``data`` as {thread name (digits dropped): {library: % of the process's samples}}."""
    report = subprocess.run(["perf", "report", "-i", str(data), "--sort", "comm,dso", "--stdio",
                             "--field-separator", "\t", "-F", "overhead,comm,dso"],
                            capture_output=True, text=True, check=False).stdout
    out: dict[str, dict[str, float]] = {}
    for line in report.splitlines():
        fields = [field.strip() for field in line.split("\t")]
        if line.startswith("#") or len(fields) != 3 or not fields[0].endswith("%"):
            continue
        thread = re.sub(r"\d+", "", fields[1]) or "?"
        group = out.setdefault(thread, {})
        label = library(fields[2])
        group[label] = round(group.get(label, 0.0) + float(fields[0].rstrip("%")), 2)
    return {thread: dict(sorted(libs.items(), key=lambda item: -item[1])) for thread, libs in
            sorted(out.items(), key=lambda item: -sum(item[1].values()))}


def node_processes(launcher_pid: int) -> dict[str, int]:
    """The launcher's node processes by node name ("a+b" for a group), the report and helpers left out."""
    import psutil

    processes = {}
    for child in psutil.Process(launcher_pid).children(recursive=True):
        name = NodeSampler.process_name(child)
        if name and name != "report" and "launcher" not in name and name != "link capture":
            processes[name] = child.pid
    return processes


def profile_when_up(run_dir: Path, out_dir: Path, seconds: float, rate: int, settle: float, found: dict,
                    perf: bool = False):
    """A ``while_running`` for bench.run_sampled: wait for run.json plus ``settle`` seconds, then py-spy every node
    process for ``seconds`` at ``rate`` Hz, into ``out_dir`` (and ``perf`` records beside); ``found`` gets
    {name: (raw file, CPU by thread, CPU by library or None)}."""
    def profile(launcher_pid: int) -> None:
        deadline = time.monotonic() + 120.0
        while not (run_dir / "run.json").exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        time.sleep(settle)
        spies, perfs = {}, {}
        for name, pid in node_processes(launcher_pid).items():
            raw = out_dir / f"{name}.txt"
            if perf:
                perfs[name] = (out_dir / f"{name}.perf", subprocess.Popen(
                    ["perf", "record", "-q", "-e", "cpu-clock", "-F", "499", "-p", str(pid), "-o",
                     str(out_dir / f"{name}.perf"), "--", "sleep", str(int(seconds))],
                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
            spies[name] = (pid, raw, thread_cpu(pid), subprocess.Popen(
                ["py-spy", "record", "--pid", str(pid), "--rate", str(rate), "--duration", str(int(seconds)),
                 "--format", "raw", "--gil", "--nonblocking", "--output", str(raw)],
                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True))
        for name, (pid, raw, before, spy) in spies.items():
            _, error = spy.communicate(timeout=seconds + 60.0)
            libraries = None
            if name in perfs:
                data, recorder = perfs[name]
                recorder.wait(timeout=seconds + 60.0)
                libraries = perf_report(data) if data.exists() else None
            if spy.returncode == 0 and raw.exists():
                found[name] = (raw, cpu_difference(before, thread_cpu(pid)), libraries)
            else:
                why = error.strip().splitlines()[-1] if error.strip() else f"exit {spy.returncode}"
                print(f"[profile] py-spy on {name}: {why}", file=sys.stderr)
    return profile


def print_table(result: dict) -> None:
    for name, entry in result["processes"].items():
        threads = entry["thread_cpu_s"]
        print(f"\n{name}: {entry.get('cpu_s', '?')} CPU-s in the whole run; in the {result['seconds_sampled']:g} s "
              f"window {sum(threads.values()):.2f} CPU-s: " + ", ".join(f"{k} {v:g}" for k, v in threads.items()))
        for thread, libraries in (entry.get("perf_by_thread") or {}).items():
            print(f"  perf, {thread}: " + ", ".join(f"{label} {share:g} %" for label, share in libraries.items()))
        print(f"  Python with the GIL held, {entry['samples']} samples:")
        for label, share in entry["categories"].items():
            print(f"  {share:5.1f} %  {label}")
        print("  top functions: " + "; ".join(f"{fn} {share} %" for fn, share in entry["top_functions"].items()))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="how long each node is sampled [s]")
    parser.add_argument("--rate", type=int, default=200, help="samples a second")
    parser.add_argument("--settle", type=float, default=6.0,
                        help="[s] after the launcher's run.json before sampling (the operator starts at 4 s)")
    parser.add_argument("--launcher-args", default="", help="more launcher options, one string")
    parser.add_argument("--perf", action="store_true", help="also CPU by library with Linux perf (root)")
    parser.add_argument("--out", type=Path, default=None, help="JSON (default results/profile_graph.json)")
    args = parser.parse_args(argv)
    if shutil.which("py-spy") is None:
        print("[profile] py-spy is not installed (scripts/setup.sh installs it into the venv)", file=sys.stderr)
        return 2
    stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
    run_dir = REPO / "runs" / f"profile-{stamp}"
    raw_dir = Path(tempfile.mkdtemp(prefix="profile_graph_"))
    found: dict[str, tuple[Path, dict, dict | None]] = {}
    command = [str(REPO / "scripts" / "run_teleop.sh"), "--out", str(run_dir), "--no-video", "--no-report",
               *shlex.split(args.launcher_args)]
    run_dir.parent.mkdir(parents=True, exist_ok=True)
    code, wall, nodes = run_sampled(command, run_dir.with_suffix(".log"),
                                    profile_when_up(run_dir, raw_dir, args.seconds, args.rate, args.settle, found,
                                                    perf=args.perf and shutil.which("perf") is not None))
    processes = {}
    for name, (raw, threads, libraries) in sorted(found.items()):
        processes[name] = {"cpu_s": nodes.get(name, {}).get("cpu_s"), "thread_cpu_s": threads,
                           "perf_by_thread": libraries, **summarise(read_raw(raw))}
    result = {"date": datetime.now().isoformat(timespec="seconds"), "command": command, "exit_code": code,
              "wall_s": round(wall, 1), "seconds_sampled": args.seconds, "rate_hz": args.rate,
              "load_average": list(os.getloadavg()), "processes": processes}
    out = args.out or REPO / "results" / "profile_graph.json"
    write_json(out, result)
    print_table(result)
    print(f"\n[profile] main job exit {code}; {out}")
    shutil.rmtree(raw_dir, ignore_errors=True)
    return 0 if processes else 1


if __name__ == "__main__":
    sys.exit(main())
