#!/usr/bin/env python3
"""Start the whole teleoperation graph, record it, stop it cleanly, and report it.

This is what `scripts/run_teleop.sh` runs. It is a small launch file in Python (the ROS 2 launch system is not
available from the wheels): each node is its own process, started with `ros2 run` where the ros2 CLI exists and
otherwise by executing the very file `ros2 run` would (install/<pkg>/lib/<pkg>/<exe>). Ctrl-C (or the end of
the run) stops the nodes in reverse order with SIGINT, so the recorder still finalises its bag, then the report
is written.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

from fic_teleop_bringup import (
    cpu_placement,
    dds_transport,
    demonstrations,
    hardware_twin,
    node_groups,
    run_bag,
    run_profile,
    two_stations,
)
from fic_teleop_bringup.launch_checks import (
    ArgumentRefusal,
    check_options,
    domain_from_environment,
    prepare_run_folder,
    whole_states_per_tick,
)
from fic_teleop_bringup.launch_isolation import DomainBusy, isolate
from fic_teleop_bringup.launch_supervision import (
    EXIT_CODES,
    EXIT_REFUSED,
    EXIT_STARVED,
    die_with_launcher,
    failed_nodes,
    fill_limit_counters,
    safety_verdict,
)
from fic_teleop_bringup.launch_timing import (
    JUDGED_RECORDS,
    SimulatedWindow,
    TimingBounds,
    exit_code,
    judge_run,
    judged_topics,
)
from fic_teleop_bringup.realtime_scheduling import RealtimeScheduler, leave_real_time_class
from fic_teleop_bringup.run_bag import RunBag
from fic_teleop_bringup.workspace import CONFIG, REPO
from fic_teleop_runtime.parameters import file_sections
from fic_teleop_runtime.params_file import write_node_params
from fic_teleop_runtime.record_batch import stream_readers
from fic_teleop_runtime.workspace import executable
from sim_bridge.device.closed_loop_operator import VIDEO_RATE_HZ

# How long a node may take to stop after SIGINT before it is killed; the recorder finalises its bag, so it gets more.
# A starved node can need longer (measured: a device and master under a 40 % CPU quota), which the verdict then says
# (launch_supervision.safety_verdict).
STOP_TIMEOUT_S, RECORDER_STOP_TIMEOUT_S = 15.0, 60.0
SCRIPT_CIRCLE_START_S = 2.0     # circle_start_time of config/operator_scripts/superimposition.yaml
PLANNER_LAG_S = 0.2             # the harmonic planner's lag behind the circle at 0.126 m/s (measured)
# Every difference between the run modes (rates, clocks, groups, priorities, per-node values) is a run profile,
# fic_teleop_bringup/profiles/*.yaml (run_profile.py).


@dataclass
class NodeSpec:
    package: str
    executable: str
    name: str
    params_file: str | None = None
    params: dict = field(default_factory=dict)
    foreground: bool = False  # the interactive keyboard operator owns the terminal
    niceness: int | None = None  # negative: ahead of the recorder (the profile's niceness); None: unchanged
    fifo_priority: int | None = None  # SCHED_FIFO priority of its loop threads (realtime_scheduling.py); None: none
    cpu: int | None = None  # the CPU its process runs on (cpu_placement.py); None: the scheduler's choice
    extra_params_files: list[str] = field(default_factory=list)  # after params_file (a driver profile, config/profiles)
    remaps: dict[str, str] = field(default_factory=dict)         # topic remaps (a driver profile's remaps.yaml)
    members: list["NodeSpec"] = field(default_factory=list)      # --group: the nodes sharing this process


def node_command(spec: NodeSpec, run_params: Path | None = None) -> list[str]:
    """The node's command line: its config file, then `run_params`, the launcher's own values for this run
    (a params file written by fic_teleop_runtime.params_file.write_node_params, so that each value keeps its Python
    type)."""
    installed = executable(spec.package, spec.executable)
    if shutil.which("ros2") and os.environ.get("FIC_TELEOP_NO_ROS2_CLI") != "1":
        command = ["ros2", "run", spec.package, spec.executable]
    else:
        command = [str(installed)]
    command += ["--ros-args", "-r", f"__node:={spec.name}"]
    if spec.params_file:
        command += ["--params-file", str(CONFIG / spec.params_file)]
    for extra in spec.extra_params_files:
        command += ["--params-file", str(CONFIG / extra)]
    for source, target in spec.remaps.items():
        command += ["-r", f"{source}:={target}"]
    if run_params is not None:
        command += ["--params-file", str(run_params)]
    return command


def params_files(values: list[str]) -> list[tuple[str, Path]]:
    """``--params-file NODE=FILE`` values -> [(node, absolute path)]; ArgumentRefusal names a malformed value or a
    file that cannot be read."""
    result = []
    for value in values:
        node, separator, path = value.partition("=")
        if not separator or not node or not path:
            raise ArgumentRefusal(f"--params-file needs NODE=FILE, got {value!r}")
        resolved = Path(path).expanduser().resolve()
        if not resolved.is_file() or not os.access(resolved, os.R_OK):
            raise ArgumentRefusal(f"--params-file {node}: {path} is not a readable file")
        result.append((node, resolved))
    return result


OPERATORS = ("scripted", "closed-loop", "shape-sorting")
# The video the closed-loop and the shape-sorting operators watch (sim_bridge/device/haptic_device_node.py reads it:
# the TCP and every movable body, the shape_sorting scene's pieces), after channel_backward's own routes
# (config/channel.yaml).
VIDEO_ROUTES = ["/sim/tcp_pose:/master/video/tcp_pose:geometry_msgs/msg/PoseStamped",
                "/sim/object_poses:/master/video/object_poses:geometry_msgs/msg/PoseArray"]


def graph(args: argparse.Namespace, bag_path: Path) -> list[NodeSpec]:
    """The paper's architecture (README.md, "Architecture"): device -> master -> channel -> replica -> robot, and
    back."""
    profile = getattr(args, "run_profile", None) or run_profile.resolve(args)
    lockstep = args.time_mode == "lockstep"
    sim_time = {"use_sim_time": profile["use_sim_time"]}
    channel = {
        "delay": args.delay,
        "jitter": args.jitter,
        "drop_probability": args.drop,
        "lost_from": args.blackout_at if args.blackout_at is not None else -1.0,
        "rate_cap_hz": args.rate_cap,
        "seed": args.seed,
    }
    if args.blackout_window:
        channel["blackout_windows"] = [float(t) for t in args.blackout_window]
    operator = "joy" if args.interactive else args.operator.replace("-", "_")
    # One origin for the operator script and the planner's circle: the script steers around the obstacles where
    # the circle will be (its circle_start_time, 2 s, less the harmonic planner's lag of about 0.2 s behind its
    # source at the circle's speed, measured). Sim time starts at 0 in lockstep; in realtime, a few seconds
    # from now on the wall clock, once every node is up.
    planner_timing, operator_timing = {}, {}
    if args.scene == "superimposition" and args.trajectory == "circle" and not args.interactive:
        origin = (0.0 if profile["use_sim_time"] else time.time()) + profile["start_margin_s"]
        operator_timing = {"script_start_time": origin, **_script_for_delay(args.delay, bag_path.parent)}
        planner_timing = {"start_time": origin + SCRIPT_CIRCLE_START_S - PLANNER_LAG_S}
        if args.quiet_tail > 0.0:   # the task is --duration from the run's start (the origin in realtime)
            quiet_from = (origin if not profile["use_sim_time"] else 0.0) + args.duration
            operator_timing["quiet_from"] = planner_timing["stop_time"] = quiet_from
    closed_loop = operator in ("closed_loop", "shape_sorting")   # an operator that watches the video
    joint_states, recorded_joint_states = {}, {}
    if args.joint_state_rate is not None:   # the recorder counts gaps on the same grid (launch_checks.py checks it)
        joint_states = {"joint_state_rate_hz": args.joint_state_rate}
        recorded_joint_states = {"joint_states_period": 1.0 / args.joint_state_rate}
    # The closed-loop operator's video: the robot's poses at a webcam's 30 Hz, over the backward link.
    video = {"object_pose_rate_hz": VIDEO_RATE_HZ} if closed_loop else {}
    backward_routes = {"routes": [*_configured_routes("channel_backward"), *VIDEO_ROUTES],
                       "logged_deliveries": [*_configured_section("channel_backward").get("logged_deliveries", []),
                                             *(route.split(":")[1] for route in VIDEO_ROUTES)]} if closed_loop else {}
    watcher = {"assumed_one_way_delay": args.delay} if closed_loop else {}
    nodes = [
        NodeSpec("sim_bridge", "robot_node", "robot", "robot.yaml",
                 {"scene": args.scene, "mode": args.time_mode, "seed": args.seed, **video,
                  **joint_states}),
        NodeSpec("fic_teleop_tools", "recorder_node", "recorder", None,
                 {"bag_path": str(bag_path), **sim_time, **recorded_joint_states,
                  # --live: the recorder, which holds every topic's bytes already, serves the live view
                  **({"live_port": args.live_port, "live_host": args.live_host} if args.live else {})}),
        NodeSpec("fic_teleop_replica", "replica_node", "replica", "replica.yaml",
                 {"controller": replica_controller(args.controller), "control_rate": args.control_rate,
                  "channel_passivity_control": tdpa(args),
                  # With the loops pre-empting (fifo), a new command used at the next joint state gave a latency p50
                  # of 1.3 and 1.7 ms in two runs, against 1.8-2.6 ms in five without; under niceness the extra
                  # ticks only added load (A/B in one session: no gain).
                  "tick_on_command": args.scheduling == "fifo",
                  # the channel's delay must fit inside the replica's command-age bound (input_guard.py)
                  "max_command_age": 3.0 + args.delay + args.jitter,
                  **sim_time}),
        NodeSpec("fic_teleop_planner", "planner_node", "planner", "planner.yaml",
                 {"trajectory": args.trajectory, **planner_timing, **sim_time}),
        NodeSpec("sim_bridge", "channel_node", "channel_forward", "channel.yaml", {**channel, **sim_time}),
        NodeSpec("sim_bridge", "channel_node", "channel_backward", "channel.yaml",
                 {**channel, "seed": args.seed + 1, **backward_routes, **sim_time}),  # its own random stream
        NodeSpec("fic_teleop_master", "master_node", "master", "master.yaml",
                 {"channel_passivity_control": tdpa(args), **sim_time}),
        NodeSpec("sim_bridge", "haptic_device_node", "haptic_device", "haptic_device.yaml",
                 {"scene": args.scene, "operator_source": operator, **operator_timing, **watcher, **sim_time}),
    ]
    if args.interactive:
        nodes.append(NodeSpec("sim_bridge", "keyboard_operator", "keyboard_operator", None, {}, foreground=True))
    if args.hardware_twin:
        nodes = hardware_twin.twin_graph(nodes, lockstep, NodeSpec)
    for spec in nodes:   # the profile's values for each node, under the options' own
        spec.params = {**run_profile.node_parameters(profile, spec.name, lockstep), **spec.params}
    by_name = {spec.name: spec for spec in nodes}
    if lockstep and by_name.get("robot") and by_name["robot"].params.get("lockstep_peers"):
        # The channels are /clock followers as the device, master and planner are: the simulation waits for their
        # heartbeat too (sim_bridge/channel/channel_node.py), so a channel that lags holds the run, not the commands.
        for name in ("channel_forward", "channel_backward"):
            if name in by_name:
                by_name[name].params["lockstep_heartbeat"] = True
                by_name["robot"].params["lockstep_peers"] = [*by_name["robot"].params["lockstep_peers"],
                                                             f"/{name}/heartbeat"]
    if args.no_peer_barrier and "robot" in by_name:
        by_name["robot"].params.pop("lockstep_peers", None)
    step_clock = by_name["robot"].params.get("step_clock_topic") if lockstep and "robot" in by_name else None
    if step_clock and "replica" in by_name:
        # The replica answers every state and reads its time at each one (the robot's step clock, published before
        # the state); every other node follows /clock, at the profile's coarser rate (docs/CONVENTIONS.md, "Time").
        by_name["replica"].remaps["/clock"] = step_clock
    for node, path in params_files(args.params_file):
        if node not in by_name:
            raise ArgumentRefusal(f"--params-file: no node {node!r} in this graph (its nodes: {', '.join(by_name)})")
        by_name[node].extra_params_files.append(str(path))
    if args.scheduling != "default":
        for spec in nodes:
            spec.niceness = profile["niceness"].get(spec.name)
            if args.scheduling == "fifo":
                spec.fifo_priority = profile["fifo_priorities"].get(spec.name)
    return nodes


def replica_controller(controller: str) -> str:
    """The replica's law for --controller: linear_tdpa is linear_bounded behind the channel's TDPA."""
    return "linear_bounded" if controller == "linear_tdpa" else controller


def tdpa(args: argparse.Namespace) -> bool:
    """The channel ports' passivity controllers act (fic_core.channel_ports): --tdpa, or --controller linear_tdpa."""
    return bool(args.tdpa or args.controller == "linear_tdpa")


def _configured_section(node: str) -> dict:
    """A channel node's own section of config/channel.yaml."""
    return file_sections(CONFIG / "channel.yaml")[node]


def _configured_routes(node: str) -> list[str]:
    """A channel node's routes as config/channel.yaml gives them."""
    return list(_configured_section(node)["routes"])


def _script_for_delay(delay: float, run_dir: Path) -> dict[str, str]:
    """The E1 script timed for the run's one-way delay (the checked-in one anticipates its own, 0.2 s): written
    into the run folder and given to the device node; nothing at the checked-in delay."""
    from sim_bridge.device.operator_scripts import SUPERIMPOSITION_DEFAULTS, superimposition_script, write_script

    if math.isclose(delay, float(SUPERIMPOSITION_DEFAULTS["one_way_delay"])):
        return {}
    run_dir.mkdir(parents=True, exist_ok=True)
    path = write_script(superimposition_script({"one_way_delay": delay}), run_dir / "operator_script.yaml")
    return {"script_file": str(path.resolve())}


def _prioritised(niceness: int | None):
    """A preexec function that sets the node's niceness; refused (needs root or CAP_SYS_NICE), the node runs at the
    default and the launcher says so (Graph.prioritised)."""
    if niceness is None:
        return None

    def apply() -> None:
        try:
            os.setpriority(os.PRIO_PROCESS, 0, niceness)
        except OSError:
            pass
    return apply


class Graph:
    """The running processes, stopped in reverse start order."""

    def __init__(self, log_dir: Path) -> None:
        self.log_dir = log_dir
        self.processes: list[tuple[NodeSpec, subprocess.Popen, object]] = []
        self.early_exits: list[str] = []  # nodes that ended before the run did
        self.killed_at_stop: list[str] = []   # nodes that did not stop on SIGINT within the stop's timeout
        self.scheduler = RealtimeScheduler()
        self.wrap = None   # two stations: runs each node in its station's namespace (two_stations.py)

    def start(self, spec: NodeSpec) -> None:
        params_dir = self.log_dir.parent / "params"
        if spec.members:
            command = node_groups.group_command(spec, node_command,
                                                lambda name, params: write_node_params(params_dir, name, params))
        else:
            command = node_command(spec, write_node_params(params_dir, spec.name, spec.params))
        # Every node gets SIGTERM if the launcher dies, however it dies (launch_supervision.py); our own executables
        # start with the stop signals blocked until their handlers are in (a `ros2 run` wrapper would not unblock).
        preexec = die_with_launcher(os.getpid(),
                                    then=cpu_placement.chained(_prioritised(spec.niceness),
                                                               cpu_placement.pinned(spec.cpu)),
                                    block_stop_signals=command[0] != "ros2")
        if self.wrap is not None:
            command = self.wrap(spec.name, command)
        if spec.foreground:
            process = subprocess.Popen(command, preexec_fn=preexec)
            log = None
        else:
            log = open(self.log_dir / f"{spec.name}.log", "wb")
            process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
                                       preexec_fn=preexec)
        self.processes.append((spec, process, log))
        if spec.members and log is not None:
            node_groups.link_member_logs(self.log_dir, spec)
        if spec.fifo_priority is not None:
            self.scheduler.register(spec.name, process.pid, spec.fifo_priority)

    def prioritised(self) -> dict[str, bool]:
        """For each node that asked for a negative niceness, whether it runs with it."""
        granted = {}
        for spec, process, _ in self.processes:
            if spec.niceness is not None:
                try:
                    granted[spec.name] = os.getpriority(os.PRIO_PROCESS, process.pid) == spec.niceness
                except OSError:  # already gone
                    granted[spec.name] = False
        return granted

    def dead(self) -> list[str]:
        return [spec.name for spec, process, _ in self.processes if process.poll() is not None and not spec.foreground]

    def foreground_done(self) -> bool:
        return any(spec.foreground and process.poll() is not None for spec, process, _ in self.processes)

    def stop(self, timeout: float = STOP_TIMEOUT_S,
             recorder_timeout: float = RECORDER_STOP_TIMEOUT_S) -> dict[str, int]:
        """SIGINT to each node in reverse start order, the recorder last; a node still running ``timeout`` seconds
        later (the recorder: ``recorder_timeout``) is killed and named in ``killed_at_stop``."""
        codes: dict[str, int] = {}
        order = [entry for entry in reversed(self.processes) if entry[0].name != "recorder"] + \
                [entry for entry in self.processes if entry[0].name == "recorder"]
        for spec, process, _log in order:  # the recorder stops last, so it records the others' last messages
            codes[spec.name], killed = _interrupt(process, recorder_timeout if spec.name == "recorder" else timeout)
            if killed:
                self.killed_at_stop.append(spec.name)
        for spec, _, log in self.processes:
            if log:
                log.close()
                if spec.members:   # each member's own log again (node_groups.split_log)
                    node_groups.split_log(self.log_dir, spec)
        return codes


def _node_parameter(specs: list, name: str):
    """The first value of parameter ``name`` the graph's nodes are given (a group's members too), None if none is."""
    return next((node.params[name] for spec in specs for node in (spec.members or [spec]) if name in node.params),
                None)


def _interrupt(process: subprocess.Popen, timeout: float) -> tuple[int, bool]:
    """SIGINT, then SIGKILL after ``timeout`` s: (the exit code, whether it had to be killed)."""
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
            return process.returncode, True
    return process.returncode, False


def wait_for_sim_time(duration: float, graph_: Graph, wall_limit: float, stop: threading.Event,
                      wall_origin: float | None = None, progress=None, watch=None) -> SimulatedWindow:
    """Block until the simulation has run `duration` seconds of its own time (read from /clock), or `stop` is set;
    return the run's window on that clock (what the bag's share is judged against, launch_timing.py).

    ``wall_origin`` (realtime, a scripted scene): the duration counts from the first /clock at or after this
    wall-clock time, when the operator script and the circle start, so that the whole script is run.
    ``progress(elapsed, joint_state_readers)`` is called at each turn once the run has started, with the number of
    /joint_states readers; ``watch`` = (topic, seen): ``seen(wall_time)`` for each TeleoperationCommand on it."""
    import rclpy
    from rclpy.experimental import EventsExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rclpy.signals import SignalHandlerOptions
    from rclpy.task import Future
    from rosgraph_msgs.msg import Clock

    from fic_teleop_runtime.cdr_header import header_stamp, stamp_seconds

    # Our own Ctrl-C handling (a flag set by main's signal handler) stops the graph in order; rclpy's would only end
    # the wait. The handler must not raise: an exception raised while rclpy's C++ layer converts a message comes out
    # as a pybind11 RuntimeError instead of a KeyboardInterrupt.
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("fic_teleop_launcher")
    latest = {"t": None, "start": None}

    def on_clock(data: bytes) -> None:
        # Raw: a Clock's CDR is a Time at the place of a header's stamp, read without building the message (this
        # node takes every /clock message of the run, 500 a simulated second in lockstep).
        stamp = header_stamp(data)
        if stamp is None:
            return
        now = stamp_seconds(stamp)
        latest["t"] = now
        if latest["start"] is None and (wall_origin is None or time.time() >= wall_origin):
            latest["start"] = now

    node.create_subscription(Clock, "/clock", on_clock, QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT),
                             raw=True)
    if watch is not None:
        from fic_teleop_msgs.msg import TeleoperationCommand
        topic, seen = watch
        # raw: only the arrival time is read, so the 100 Hz command is not deserialised
        node.create_subscription(TeleoperationCommand, topic, lambda _data: seen(time.time()),
                                 QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT), raw=True)
    wall_start = time.monotonic()
    last_print = last_scheduling = 0.0
    # The checks below a tenth of a second apart, not once per /clock message: the EventsExecutor takes every message
    # of the slice (as the nodes' spin loop does, fic_teleop_runtime/spin.py). One rclpy.spin_once and one round of
    # checks per message (100 Hz in realtime) cost the launcher about a CPU-second a run.
    executor = EventsExecutor()
    executor.add_node(node)
    never = Future()
    try:
        while rclpy.ok() and not stop.is_set():
            executor.spin_until_future_complete(never, timeout_sec=0.1)
            # Threads appear while the nodes start (executor, DDS participant, the robot's physics thread): look for
            # new ones often at first, then rarely.
            since_start = time.monotonic() - wall_start
            if time.monotonic() - last_scheduling > (0.2 if since_start < 20.0 else 2.0):
                last_scheduling = time.monotonic()
                graph_.scheduler.apply()
            elapsed = 0.0 if latest["start"] is None else latest["t"] - latest["start"]
            if progress is not None and latest["start"] is not None:
                # two stations: the link cut counts run time as --duration does
                progress(elapsed, stream_readers(node, "/joint_states"))
            if elapsed >= duration or graph_.foreground_done():
                break
            dead = graph_.dead()
            graph_.early_exits = dead
            if dead:
                print(f"[run] node(s) exited early: {', '.join(dead)} (see their logs)", file=sys.stderr)
                break
            if time.monotonic() - wall_start > wall_limit:
                print(f"[run] wall-clock limit {wall_limit:.0f} s reached at sim time {elapsed:.1f} s", file=sys.stderr)
                break
            if time.monotonic() - last_print > 5.0:
                last_print = time.monotonic()
                print(f"[run] sim time {elapsed:5.1f} / {duration:.0f} s", flush=True)
    finally:
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        rclpy.try_shutdown()
    return SimulatedWindow(0.0, 0.0) if latest["start"] is None else SimulatedWindow(latest["start"], latest["t"])


def _report_scheduling(running: Graph, run_dir: Path) -> None:
    """Say which loops run under SCHED_FIFO (or were refused it), and keep it in run.json."""
    summary = running.scheduler.summary()
    if not summary:
        return
    refused = running.scheduler.refused()
    applied = [f"{name} {entry['priority']} ({entry['threads']} threads)" for name, entry in summary.items()
               if entry["policy"] == "fifo"]
    if applied:
        print(f"[run] SCHED_FIFO: {', '.join(applied)}")
    if refused:
        print(f"[run] warning: SCHED_FIFO refused for {', '.join(refused)} ({next(iter(refused.values()))}; needs root "
              "or CAP_SYS_NICE): they run at their niceness, and the pipeline latency is longer (docs/RESULTS.md)",
              file=sys.stderr)
    _add_to_run_record(run_dir, "realtime_scheduling", summary)


def _scanned(bag: Path, topics: set[str]) -> RunBag | None:
    """The run's bag read once for the launcher's verdicts; None without a bag, or when it cannot be read (each
    verdict then reads what it can itself)."""
    if not bag.exists():
        return None
    try:
        return run_bag.scan(bag, topics, JUDGED_RECORDS)
    except Exception as error:  # noqa: BLE001 - a torn or foreign bag: the verdicts go on with their own reads
        print(f"[run] the bag could not be read for the verdicts ({error})")
        return None


def _add_to_run_record(run_dir: Path, key: str, value) -> None:
    """Add what the run learned while starting to its run.json."""
    run_record = json.loads((run_dir / "run.json").read_text())
    run_record[key] = value
    (run_dir / "run.json").write_text(json.dumps(run_record, indent=2))


def parse_arguments(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="exit codes: " + "; ".join(f"{code} {text}" for code, text
                                                                       in EXIT_CODES.items()))
    parser.add_argument("--scene", default="superimposition", choices=["superimposition", "shape_sorting",
                                                                       "free_space"])
    parser.add_argument("--duration", type=float, default=30.0, help="simulated seconds to run (default 30)")
    parser.add_argument("--quiet-tail", type=float, default=0.0,
                        help="seconds of quiet tail after --duration (the scripted superimposition run): the planner's "
                             "circle stops, the operator's target holds still, the hand keeps holding the handle; the "
                             "run verdict then judges stability by the loop's free response there "
                             "(docs/EXPERIMENTS.md, 'The run verdict'); default 0: none")
    parser.add_argument("--delay", type=float, default=0.2, help="one-way channel delay [s], both ways (default 0.2)")
    parser.add_argument("--jitter", type=float, default=0.0, help="delay jitter [s]")
    parser.add_argument("--drop", type=float, default=0.0, help="drop probability in [0, 1]")
    parser.add_argument("--blackout-at", type=float, default=None,
                        help="total loss of communication, both ways, from this many seconds after the channel starts")
    parser.add_argument("--blackout-window", type=float, nargs=2, metavar=("START", "END"), default=None,
                        help="total loss of communication, both ways, between these times after the channel starts")
    parser.add_argument("--rate-cap", type=float, default=0.0, help="channel rate cap [Hz], 0 = none (paper: 10 Hz)")
    parser.add_argument("--controller", default="fic", choices=["fic", "linear", "linear_bounded", "linear_tdpa"],
                        help="replica controller; linear_tdpa: linear_bounded behind the channel's time-domain "
                             "passivity controllers (as --tdpa)")
    parser.add_argument("--tdpa", action="store_true",
                        help="the channel's time-domain passivity controllers act at both ports around any "
                             "--controller (the observers always run; docs/CONTROL_LAWS.md, \"The channel's ports\")")
    parser.add_argument("--paper-law", action="store_true",
                        help="the replica's Eq. 7 as the paper writes it: no inertial feedforward and no friction "
                             "compensation (by default both are on, config/replica.yaml)")
    parser.add_argument("--control-rate", type=float, default=None,
                        help="replica control rate [Hz] (default: the profile's control_rate_hz, 1000 in lockstep, "
                             "the paper's rate; 500 in realtime)")
    parser.add_argument("--joint-state-rate", type=float, default=None, metavar="HZ",
                        help="realtime: the robot's /joint_states rate, a divisor of 1000 not below the replica's "
                             "control rate (default: the replica's 500 Hz, 1000 with a faster replica or the driver "
                             "twin; docs/RESULTS.md \"Graph levers\")")
    parser.add_argument("--trajectory", default=None, choices=["circle", "fixed", "via_points"],
                        help="planner trajectory (default: the circle for superimposition, a fixed point otherwise)")
    parser.add_argument("--no-peer-barrier", action="store_true",
                        help="lockstep: step on the replica's answers only, without waiting for the device, master "
                             "and planner to keep up (how lockstep ran before; runs then depend on the machine's load)")
    parser.add_argument("--time-mode", default=None, choices=list(run_profile.TIME_MODES),
                        help="realtime (default): wall-clock paced; lockstep: the sim waits for each command "
                             "(deterministic; the lockstep profile)")
    parser.add_argument("--profile", default=None, metavar="NAME|PATH.yaml",
                        help="a run profile: a built-in one by name (realtime, lockstep, paper_law, hardware_twin, "
                             "two_stations: the same as their options) or a YAML file of one's own, applied last over "
                             "the layers its options and the command line select (fic_teleop_bringup/profiles, "
                             "docs/ARCHITECTURE.md \"Bringup\")")
    parser.add_argument("--interactive", action="store_true", help="drive the operator's hand from the keyboard")
    parser.add_argument("--operator", default=None, choices=OPERATORS,
                        help="superimposition: scripted (the E1 script, timed for --delay) or closed-loop (times its "
                             "moves from the replica's video after the backward channel, docs/EXPERIMENTS.md "
                             "\"Operators\"); shape_sorting: shape-sorting (looks, aligns and feels through the "
                             "delay, docs/EXPERIMENTS.md \"E2\") or scripted (default: shape-sorting in the "
                             "shape_sorting scene, scripted otherwise)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=Path, default=None, help="run folder (default runs/<date-time>)")
    parser.add_argument("--domain-id", type=int, default=None,
                        help="ROS_DOMAIN_ID for this run (0-101 or 215-232); default: ROS_DOMAIN_ID if set, else a "
                             "domain reserved on this machine for the run; refused if another graph is heard on it")
    parser.add_argument("--wall-limit", type=float, default=None,
                        help="give up after this many wall-clock seconds (default max(120, 6 x duration); lockstep "
                             "on a loaded 2-core machine can run at 0.1x real time)")
    parser.add_argument("--no-report", action="store_true")
    parser.add_argument("--no-video", action="store_true", help="skip the key frames and the animation")
    parser.add_argument("--scheduling", choices=["nice", "fifo", "default"], default="nice",
                        help="nice (default): the loops' nodes at negative niceness, ahead of the recorder; fifo "
                             "(realtime only, opt-in): also their threads under SCHED_FIFO along the data path, "
                             "lower pipeline latency but on 2 cores the recorder can lose joint states "
                             "(fic_teleop_bringup/realtime_scheduling.py); default: every node as the shell starts it")
    parser.add_argument("--no-priority", action="store_true", help="the same as --scheduling default")
    parser.add_argument("--cpu-placement", choices=cpu_placement.PLACEMENTS, default="none",
                        help="none (default): the scheduler places every node; profile: each node process on the CPU "
                             "the run profile's cpu_placement names, about 5 %% less CPU on 2 cores but longer "
                             "control tick gaps when a new participant joins the graph "
                             "(fic_teleop_bringup/cpu_placement.py)")
    two_stations.add_arguments(parser)
    hardware_twin.add_arguments(parser)
    demonstrations.add_arguments(parser)
    parser.add_argument("--group", action="append", metavar="NODE,NODE[,...]",
                        help="run these nodes in one process, each still its own node (repeatable; e.g. "
                             "channel_forward,channel_backward); replaces the default groups (the channel pair; the "
                             "device and the master): fewer processes, less isolation (docs/RESULTS.md, \"Graph "
                             "levers\")")
    parser.add_argument("--isolated", action="store_true",
                        help="one process per node, no default groups (each node's crash its own; about 4 CPU s more "
                             "per 30 s run and a longer latency tail on 2 cores, docs/RESULTS.md)")
    parser.add_argument("--params-file", action="append", metavar="NODE=FILE", default=[],
                        help="a ROS 2 params file for one node, read after its config/ file and before the run's own "
                             "values (repeatable); the node refuses a key it does not declare")
    parser.add_argument("--live", action="store_true",
                        help="serve every topic and the arm in 3D on a Foxglove WebSocket server while the run goes "
                             "(open config/live_view.json in Foxglove or Lichtblick; docs/TOOLS.md)")
    parser.add_argument("--live-port", type=int, default=8765, help="the live view's port (default 8765)")
    parser.add_argument("--live-host", default="127.0.0.1",
                        help="the address the live view binds to (default 127.0.0.1: this machine only)")
    return parser.parse_args(argv)


def resolve_defaults(args: argparse.Namespace) -> None:
    """The run profile and the defaults that depend on it and on other arguments (also what launch_file.py writes
    the launch file from). ArgumentRefusal (run_profile.ProfileError) names a profile that cannot be used."""
    args.run_profile = profile = run_profile.resolve(args)
    if args.control_rate is None:
        args.control_rate = float(profile["control_rate_hz"])
    usable_rate = math.isfinite(args.control_rate) and args.control_rate > 0.0   # else check_options refuses it
    joint_state_rate = profile["joint_state_rate_hz"]
    if args.joint_state_rate is None and joint_state_rate is not None and usable_rate:
        # The profile's rate when the control period is a whole number of its periods (500 Hz: 500, 250, 100 Hz ...):
        # the replica's ticks fall on its states. Otherwise (a faster replica, or 300 Hz, which would tick every
        # 4 ms) every step.
        args.joint_state_rate = (float(joint_state_rate)
                                 if whole_states_per_tick(float(joint_state_rate), args.control_rate) else 1000.0)
    if args.no_priority:
        args.scheduling = "default"
    if args.operator is None:    # E2's operator closes the loop through the channel; the others play a script
        args.operator = "shape-sorting" if args.scene == "shape_sorting" else "scripted"
    if args.trajectory is None:  # E1 superimposes the paper's circle; the other scenes are the operator's alone
        args.trajectory = "circle" if args.scene == "superimposition" else "fixed"
    args.task = demonstrations.episode_task(args)   # kept in run.json: a dataset episode's task string


def main(argv: list[str] | None = None) -> int:
    args = parse_arguments(argv)
    inherited = leave_real_time_class()
    if inherited:
        print(f"[run] started under {inherited}: the launcher and its nodes run in the normal class (the loops' own "
              "real-time threads: --scheduling fifo)")
    try:
        resolve_defaults(args)
    except ArgumentRefusal as refusal:
        print(f"[run] refused: {refusal}", file=sys.stderr)
        return EXIT_REFUSED
    if args.scheduling == "fifo" and args.time_mode == "lockstep":
        print("[run] refused: --scheduling fifo is for realtime runs (lockstep waits for every answer and needs no "
              "pre-emption)", file=sys.stderr)
        return 2
    if args.live:
        from fic_teleop_tools.recording.live_view import port_in_use
        taken = port_in_use(args.live_host, args.live_port)
        if taken:
            print(f"[run] refused: the live view cannot use {args.live_host}:{args.live_port} ({taken}); "
                  "give another --live-port", file=sys.stderr)
            return 2
    run_dir = args.out or REPO / "runs" / datetime.now().strftime("%Y%m%d-%H%M%S")
    log_dir = run_dir / "logs"
    bag_path = run_dir / "bag"
    try:  # the options first: the outer two-station process and the launcher inside both refuse bad ones
        check_options(args)
        two_stations.check_arguments(args)
        params_files(args.params_file)
        groups = node_groups.parse_groups(args.group)
        node_groups.check_groups(groups, args)
    except (ArgumentRefusal, two_stations.StationError) as refusal:
        print(f"[run] refused: {refusal}", file=sys.stderr)
        return EXIT_REFUSED
    if demonstrations.is_session(args):   # the profile's episodes, each a run of this launcher, then the export
        return demonstrations.run(list(sys.argv[1:] if argv is None else argv), args, run_dir)
    if args.two_stations and not two_stations.inside_station():   # namespaces up, this launcher run inside one
        if args.print_station_commands:
            print(two_stations.station_commands(args, run_dir, graph(args, run_dir / "bag"), NodeSpec, node_command))
            return 0
        return two_stations.run(list(sys.argv[1:] if argv is None else argv), args, run_dir)
    stations = two_stations.inside_hooks(args, run_dir)
    if stations is None:   # two stations write their own Fast DDS profile (two_stations.py)
        dds_profile = args.run_profile.get("dds_profile")
        print(f"[run] {dds_transport.apply(os.environ, CONFIG / dds_profile if dds_profile else None)}")
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    # numpy's OpenBLAS would start a worker per core that busy-waits after each call: the nodes' matrices are 7x7,
    # a worker only costs CPU here (and must never be a FIFO thread, realtime_scheduling.py).
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("ROS_LOG_DIR", str(log_dir / "ros"))
    try:  # the rest the run needs, checked before anything starts (launch_checks.py, launch_isolation.py)
        given = args.domain_id if args.domain_id is not None \
            else domain_from_environment(os.environ.get("ROS_DOMAIN_ID"))
        prepare_run_folder(run_dir)
        domain = isolate(given)  # held until this process ends
    except (ArgumentRefusal, DomainBusy) as refusal:
        print(f"[run] refused: {refusal}", file=sys.stderr)
        return EXIT_REFUSED
    args.domain_id = domain.domain
    os.environ["ROS_DOMAIN_ID"] = str(domain.domain)
    if not domain.held:
        print(f"[run] domain {domain.domain}: reserved by another process (no graph heard on it)")
    (run_dir / "run.json").write_text(json.dumps({k: (str(v) if isinstance(v, Path) else v) for k,
                                                  v in vars(args).items()}, indent=2))

    running = Graph(log_dir)
    interrupted = threading.Event()

    def on_signal(signum, frame):  # the first Ctrl-C or SIGTERM ends the run early; the graph still stops cleanly
        interrupted.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    wall_start = time.monotonic()
    window = SimulatedWindow(0.0, 0.0)   # the run's duration on the simulation's clock (launch_timing.py)
    print(f"[run] scene {args.scene}, {args.duration:.0f} s, delay {args.delay * 1000:.0f} ms, controller "
          f"{args.controller}"
          f" at {args.control_rate:g} Hz, {args.time_mode}; ROS domain {domain.domain}; run folder {run_dir}")
    try:
        try:
            nodes = graph(args, bag_path)
            groups = node_groups.run_groups(groups, args, nodes)
            specs = node_groups.grouped(nodes, groups)
            linked = node_groups.link_in_process(specs, args.time_mode == "realtime", not args.hardware_twin)
            handle_linked = node_groups.link_handle_in_process(specs, args.time_mode == "realtime",
                                                               not args.hardware_twin)
            if groups:
                print(f"[run] node groups (one process each): {'; '.join(', '.join(g) for g in groups)}"
                      + ("" if args.group else " (the default; --isolated: one process per node)")
                      + ("; the robot and the replica linked without DDS" if linked else "")
                      + ("; the haptic device and the master linked without DDS" if handle_linked else ""))
                _add_to_run_record(run_dir, "node_groups", groups)
            _add_to_run_record(run_dir, "robot_replica_in_process", linked)
            _add_to_run_record(run_dir, "device_master_in_process", handle_linked)
            cpus = cpu_placement.usable_cpus()
            placement = args.run_profile.get("cpu_placement", {}) if args.cpu_placement == "profile" else {}
            placed = cpu_placement.assign(placement, specs, cpus)
            for spec in specs:
                spec.cpu = placed.get(spec.name)
            print(f"[run] {cpu_placement.describe(placed, cpus, args.cpu_placement)}")
            _add_to_run_record(run_dir, "cpu_placement", placed)
        except ArgumentRefusal as refusal:   # a node name this graph does not have: nothing started yet
            print(f"[run] refused: {refusal}", file=sys.stderr)
            return EXIT_REFUSED
        # Realtime with a scripted operator: the run's duration counts from the script's start (its origin on the
        # wall clock), so that the script's last moves are not cut by the nodes' start-up time.
        script_origin, quiet_from = _node_parameter(specs, "script_start_time"), _node_parameter(specs, "quiet_from")
        if args.quiet_tail > 0.0:
            if quiet_from is None:
                print("[run] refused: --quiet-tail needs the scripted superimposition run (its circle and operator "
                      "script), not this graph", file=sys.stderr)
                return EXIT_REFUSED
            _add_to_run_record(run_dir, "quiet_from", quiet_from)
        wall_origin = script_origin if args.time_mode == "realtime" else None
        if stations is not None:
            stations.adapt(specs, NodeSpec)
            running.wrap = stations.wrap
        for spec in specs:
            running.start(spec)
        if stations is not None:
            stations.started(wall_origin or time.time())
        granted = running.prioritised()
        if granted:
            if all(granted.values()):
                print(f"[run] scheduler priority (negative niceness) for {', '.join(granted)}")
            else:
                print(f"[run] warning: negative niceness refused for "
                      f"{', '.join(n for n, ok in granted.items() if not ok)} (needs root or CAP_SYS_NICE): on a "
                      "loaded machine expect a lower real-time factor and a longer pipeline latency", file=sys.stderr)
            _add_to_run_record(run_dir, "prioritised", granted)
        if not interrupted.is_set():
            simulated = args.duration + args.quiet_tail
            window = wait_for_sim_time(simulated, running, stop=interrupted,
                                            wall_limit=args.wall_limit or max(120.0, 6.0 * simulated),
                                            wall_origin=wall_origin,
                                            progress=stations.progress if stations is not None else None,
                                            watch=(stations.watched_topic, stations.command_seen)
                                            if stations is not None else None)
        _report_scheduling(running, run_dir)
    except KeyboardInterrupt:  # only if a signal arrived before our handler was installed
        interrupted.set()
    finally:
        if interrupted.is_set():
            print("\n[run] interrupted: stopping the graph and finalising the bag", flush=True)
        # Further Ctrl-Cs only set the flag again: they must not cut the bag's finalisation.
        if stations is not None:
            stations.stopped()   # the link up again before the nodes stop
        codes = running.stop()
        signal.signal(signal.SIGINT, signal.default_int_handler)
    wall = time.monotonic() - wall_start
    failed = failed_nodes({name: code for name, code in codes.items() if name not in running.killed_at_stop})
    print(f"[run] graph stopped after {wall:.1f} s wall, {window.length_s:.1f} s simulated"
          + (f"; nodes with errors: {failed}" if failed else "")
          + (f"; killed after no stop on SIGINT: {', '.join(running.killed_at_stop)}" if running.killed_at_stop
             else ""))
    print(f"[run] bag: {bag_path}")
    metrics, report_failed = None, False
    if not args.no_report:
        report_dir = run_dir / "report"
        command = [sys.executable, "-m", "fic_teleop_tools.report", str(bag_path), "--out", str(report_dir),
                   "--real-time-factor-target", repr(TimingBounds.from_profile(args.run_profile).real_time_factor)]
        if not args.no_video:
            command.append("--render")
        report_failed = subprocess.run(command).returncode != 0
        print(f"[run] report: {report_dir}")
        metrics_path = report_dir / "metrics.json"
        metrics = json.loads(metrics_path.read_text()) if metrics_path.exists() else None
        if metrics is not None and fill_limit_counters(metrics, log_dir):   # the bag had none: a starved recorder
            metrics_path.write_text(json.dumps(metrics, indent=2) + "\n")
            print(f"[run] limit counts from {metrics['limit_counters_source']}: {metrics['limit_violations']} "
                  "violation ticks")
    # Whether the computer kept real time, after every run; a broken safety figure still decides the code. The bag
    # read once for both verdicts (run_bag.py).
    realtime = args.time_mode == "realtime"
    scanned = _scanned(bag_path, judged_topics(run_dir) if realtime else set())
    timing = judge_run(run_dir, bag_path, metrics, TimingBounds.from_profile(args.run_profile), realtime, window,
                       killed_at_stop=running.killed_at_stop, scanned=scanned,
                       asked_s=None if interrupted.is_set() else args.duration)
    code, reasons = safety_verdict(metrics, codes, running.early_exits, report_failed, bag_path,
                                   killed_at_stop=running.killed_at_stop, starved=timing.starved,
                                   records=scanned.diagnostics if scanned is not None else None)
    for reason in reasons:
        print(f"[run] safety: {reason}", file=sys.stderr)
    for line in timing.lines():
        print(f"[run] timing: {line}", file=sys.stderr if timing.starved else sys.stdout)
    code = exit_code(code, timing, EXIT_STARVED)
    if code:
        print(f"[run] exit {code}: {EXIT_CODES[code]}", file=sys.stderr)
    return code


if __name__ == "__main__":
    sys.exit(main())
