"""Two stations on one machine: the master station and the robot station, each in its own network namespace.

`scripts/run_teleop.sh --two-stations` comes here (teleop_launcher.py hands over). What runs where is the run
profile's ``stations`` (fic_teleop_bringup/profiles/two_stations.yaml, docs/DEPLOYMENT.md), read into a
`StationLayout` (station_layout.py, which the link's analysis, station_analysis.py, reads too): the master station
holds the haptic device with the operator, the master, the master-side channel `channel_backward` and a recorder of
its own topics (bag_master/); the robot station the robot, the replica, the planner, the robot-side channel
`channel_forward` and the recorder whose bag (bag/) the report reads.

Each channel node sits on the receiving side of its direction, so it measures its hold on its own station's clock
from the moment the message arrived over the link, and only the two streams the paper's architecture needs cross
the link: the teleoperation command and the feedback wrench, each with the energy its port put into the channel
(/master/port_energy, /replica/port_energy: the channel's passivity observers, docs/CONTROL_LAWS.md "The channel's
ports"), plus DDS discovery and liveliness, measured in link_traffic.json. The master station's remaps (its
/diagnostics and /channel/deliveries under /master_station/) keep the robot station's recorder from pulling them
across the link.

The namespaces are `<namespace_prefix><tag>_master` and `..._robot`, joined by a veth pair with the profile's two
addresses; nothing is routed elsewhere. Discovery is Fast DDS's simple discovery by unicast to the two addresses,
multicast off: config/fastdds_two_stations.xml, which the run copies into its folder with the profile's addresses
as the initial peers (`write_fastdds_profile`).

Process layout: this module's `run` (the outer process, in the host's namespace) checks root, removes a leftover
pair of namespaces or refuses if one is in use, creates the pair, caps the bandwidth (tbf) if asked, starts the
capture of the link traffic in the robot station, and runs the ordinary launcher inside the robot station with
FIC_TWO_STATIONS set; that launcher starts the master station's nodes through `ip netns exec` (`wrap_command`)
and cuts the link when asked (`LinkCut`). Whatever happens (the end of the run, Ctrl-C, an error), the `finally`
of `run` stops the capture and deletes the namespaces, which takes the veth pair with them.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from fic_teleop_bringup.node_groups import linked_in_process
from fic_teleop_bringup.station_layout import StationError, StationLayout
from fic_teleop_bringup.workspace import CONFIG

INSIDE_ENV = "FIC_TWO_STATIONS"          # set in the launcher that runs inside the robot station
FASTDDS_PROFILE = CONFIG / "fastdds_two_stations.xml"
RUN_FASTDDS_PROFILE = "fastdds_two_stations.xml"   # its copy in the run folder, with the profile's addresses
TAG_PATTERN = re.compile(r"^[a-z0-9]{1,8}$")


@dataclass(frozen=True)
class StationPair:
    """Names of the two namespaces and the veth ends of one two-station run, in the profile's layout."""

    layout: StationLayout
    tag: str = "run"

    @property
    def master_namespace(self) -> str:
        return f"{self.layout.namespace_prefix}{self.tag}_master"

    @property
    def robot_namespace(self) -> str:
        return f"{self.layout.namespace_prefix}{self.tag}_robot"

    @property
    def master_interface(self) -> str:       # interface names: at most 15 characters
        return f"fic{self.tag}m"

    @property
    def robot_interface(self) -> str:
        return f"fic{self.tag}r"

    def namespace_of(self, node_name: str) -> str:
        return self.master_namespace if self.layout.station_of(node_name) == "master" else self.robot_namespace


def _ip(*arguments: str, check: bool = True) -> subprocess.CompletedProcess:
    result = subprocess.run(["ip", *arguments], capture_output=True, text=True)
    if check and result.returncode != 0:
        raise StationError(f"ip {' '.join(arguments)} failed: {result.stderr.strip()}")
    return result


def _tc(*arguments: str) -> None:
    result = subprocess.run(["tc", *arguments], capture_output=True, text=True)
    if result.returncode != 0:
        raise StationError(f"tc {' '.join(arguments)} failed: {result.stderr.strip()}")


def check_privileges() -> None:
    """Namespaces, veth pairs, tbf and packet capture need root (CAP_NET_ADMIN and CAP_SYS_ADMIN)."""
    if os.geteuid() != 0:
        raise StationError("--two-stations needs root: it creates network namespaces and a veth pair "
                           "(CAP_NET_ADMIN, CAP_SYS_ADMIN); run it as root, or run the single-host job without it")
    for tool in ("ip", "tc"):
        if shutil.which(tool) is None:
            raise StationError(f"--two-stations needs `{tool}` (iproute2) on PATH")


def namespaces() -> set[str]:
    result = _ip("netns", "list", check=False)
    return {line.split()[0] for line in result.stdout.splitlines() if line.strip()}


def namespace_pids(namespace: str) -> list[int]:
    result = _ip("netns", "pids", namespace, check=False)
    return [int(token) for token in result.stdout.split() if token.isdigit()]


def clear_leftovers(pair: StationPair) -> list[str]:
    """Remove namespaces and a veth end of this pair left by a crashed run; refuse if processes still use them.

    Returns the one-line notes of what was removed."""
    notes = []
    existing = namespaces()
    for namespace in (pair.master_namespace, pair.robot_namespace):
        if namespace not in existing:
            continue
        pids = namespace_pids(namespace)
        if pids:
            raise StationError(f"namespace {namespace} is in use by pid(s) {', '.join(map(str, pids[:8]))}: another "
                               f"two-station run? Stop it, or give --stations-tag another name")
        _ip("netns", "delete", namespace)
        notes.append(f"removed namespace {namespace} left over from an earlier run")
    for interface in (pair.master_interface, pair.robot_interface):
        if _ip("link", "show", interface, check=False).returncode == 0:   # a veth end still in the host namespace
            _ip("link", "delete", interface)
            notes.append(f"removed interface {interface} left over from an earlier run")
    return notes


def create(pair: StationPair) -> None:
    """The two namespaces, joined by one veth pair; loopback up in each (the nodes of a station talk over it)."""
    _ip("netns", "add", pair.master_namespace)
    _ip("netns", "add", pair.robot_namespace)
    _ip("link", "add", pair.master_interface, "netns", pair.master_namespace, "type", "veth",
        "peer", "name", pair.robot_interface, "netns", pair.robot_namespace)
    layout = pair.layout
    for namespace, interface, address in ((pair.master_namespace, pair.master_interface, layout.master_address),
                                          (pair.robot_namespace, pair.robot_interface, layout.robot_address)):
        _ip("-n", namespace, "link", "set", "lo", "up")
        _ip("-n", namespace, "addr", "add", f"{address}/{layout.prefix_length}", "dev", interface)
        _ip("-n", namespace, "link", "set", interface, "up")


def remove(pair: StationPair) -> list[str]:
    """Delete both namespaces (the veth pair goes with them). Processes still inside are ours: ended first."""
    notes = []
    existing = namespaces()
    for namespace in (pair.master_namespace, pair.robot_namespace):
        if namespace not in existing:
            continue
        for pid in namespace_pids(namespace):
            try:
                os.kill(pid, signal.SIGKILL)
                notes.append(f"killed pid {pid} still running in {namespace}")
            except ProcessLookupError:
                pass
        _ip("netns", "delete", namespace, check=False)
    return notes


def set_link(pair: StationPair, up: bool) -> None:
    """Both ends of the veth down (as a pulled cable: no carrier either side) or up again."""
    state = "up" if up else "down"
    _ip("-n", pair.master_namespace, "link", "set", pair.master_interface, state)
    _ip("-n", pair.robot_namespace, "link", "set", pair.robot_interface, state)


def parse_rate(text: str) -> int:
    """A tc rate ('64kbit', '10mbit', '1.5mbit') in bit/s."""
    match = re.fullmatch(r"(\d+(?:\.\d+)?)\s*(bit|kbit|mbit|gbit)", text.strip().lower())
    if not match:
        raise StationError(f"--bandwidth {text!r}: give a rate such as 64kbit, 512kbit or 10mbit")
    value = float(match.group(1)) * {"bit": 1, "kbit": 1e3, "mbit": 1e6, "gbit": 1e9}[match.group(2)]
    if not 8e3 <= value <= 1e10:
        raise StationError(f"--bandwidth {text!r}: between 8kbit and 10gbit")
    return int(value)


def cap_bandwidth(pair: StationPair, rate_bits: int) -> dict:
    """A token bucket (tbf) on the egress of both veth ends: each direction gets `rate_bits`.

    Bucket: 10 ms of the rate, at least one full-size frame (1514 B), so a datagram is never refused for its size
    alone; queue: what 100 ms of the rate drains, at least 3 frames (beyond it tbf drops, as a congested link)."""
    burst = max(1514, rate_bits // 8 // 100)
    limit = max(3 * 1514, rate_bits // 8 // 10)
    for namespace, interface in ((pair.master_namespace, pair.master_interface),
                                 (pair.robot_namespace, pair.robot_interface)):
        _tc("-n", namespace, "qdisc", "replace", "dev", interface, "root", "tbf",
            "rate", f"{rate_bits}bit", "burst", str(burst), "limit", str(limit))
    return {"rate_bit_s": rate_bits, "burst_bytes": burst, "queue_limit_bytes": limit}


def qdisc_statistics(pair: StationPair) -> dict:
    """tc's counters of both ends (sent bytes, drops, overlimits) for the record."""
    stats = {}
    for station, namespace, interface in (("master", pair.master_namespace, pair.master_interface),
                                          ("robot", pair.robot_namespace, pair.robot_interface)):
        result = subprocess.run(["tc", "-n", namespace, "-s", "qdisc", "show", "dev", interface],
                                capture_output=True, text=True)
        text = " ".join(result.stdout.split())
        sent = re.search(r"Sent (\d+) bytes (\d+) pkt \(dropped (\d+), overlimits (\d+)", text)
        stats[station] = ({"sent_bytes": int(sent.group(1)), "sent_packets": int(sent.group(2)),
                           "dropped": int(sent.group(3)), "overlimits": int(sent.group(4))} if sent else text)
    return stats


# -- the hooks the launcher calls (inside the robot station) ----------------------------------------------------

_INITIAL_PEERS = re.compile(r"<initialPeersList>.*?</initialPeersList>", re.DOTALL)
_ADDRESS = re.compile(r"<address>[^<]*</address>")


def write_fastdds_profile(layout: StationLayout, path: Path) -> Path:
    """config/fastdds_two_stations.xml with the layout's two addresses as its initial peers (master, then robot), at
    ``path``: discovery goes to the addresses the veth pair has, whatever the profile sets them to."""
    text = FASTDDS_PROFILE.read_text()
    peers = _INITIAL_PEERS.findall(text)
    if len(peers) != 1 or len(_ADDRESS.findall(peers[0])) != 2:
        raise StationError(f"{FASTDDS_PROFILE}: one initialPeersList with two addresses (master, robot) needed")
    addresses = iter((layout.master_address, layout.robot_address))
    filled = _ADDRESS.sub(lambda _: f"<address>{next(addresses)}</address>", peers[0])
    path.write_text(text.replace(peers[0], filled))
    return path


def station_environment(fastdds_profile: Path) -> dict[str, str]:
    """What every node of both stations needs in its environment: the shared Fast DDS profile and discovery."""
    return {"FASTRTPS_DEFAULT_PROFILES_FILE": str(fastdds_profile),
            "FASTDDS_DEFAULT_PROFILES_FILE": str(fastdds_profile),
            # SUBNET: rmw_fastrtps leaves the profile's discovery (unicast to the two stations) as it is;
            # LOCALHOST would pin every participant to 127.0.0.1.
            "ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}


def adapt_graph(specs: list, node_spec_class, run_dir: Path, layout: StationLayout) -> None:
    """Split the single-host graph: the robot station's recorder records its own station's topics, and the master
    station gets a recorder for its own (first in the list, so it is stopped after the others)."""
    from_recorder_node = None
    for spec in specs:
        if spec.name == "recorder":
            from_recorder_node = spec
    if from_recorder_node is None:
        return
    topics = from_recorder_node.params.get("topics") or _default_recorder_topics()
    excluded = layout.robot_station_excluded
    from_recorder_node.params["topics"] = [t for t in topics if t not in excluded]
    specs.insert(0, node_spec_class("fic_teleop_tools", "recorder_node", "recorder_master", None,
                                    {"bag_path": str(run_dir / "bag_master"), "topics": list(layout.master_topics)}))


def _default_recorder_topics() -> list[str]:
    from fic_teleop_tools.recording.recorder_node import default_topics
    return default_topics()


def master_remap_arguments(layout: StationLayout) -> list[str]:
    """The master station's remaps as ROS arguments (after the --ros-args the launcher already put in)."""
    arguments = []
    for source, target in layout.master_remaps.items():
        arguments += ["-r", f"{source}:={target}"]
    return arguments


def wrap_command(node_name: str, command: list[str], pair: StationPair, fastdds_profile: Path,
                 clock_offset_s: float = 0.0) -> list[str]:
    """The node's command run in its station: `ip netns exec <ns> env ... <command>` (exec all the way down, so
    the pid the launcher holds is the node's). Master-station nodes get their renamed topics and, for a clock
    test, a shifted wall clock (libfaketime)."""
    namespace = pair.namespace_of(node_name)
    environment = [f"{key}={value}" for key, value in station_environment(fastdds_profile).items()]
    if namespace == pair.master_namespace:
        if clock_offset_s:
            environment += faketime_environment(clock_offset_s)
        # After each --ros-args: a node group's process holds one per member (node_groups.group_command).
        remaps = master_remap_arguments(pair.layout)
        command = [part for argument in command
                   for part in ([argument, *remaps] if argument == "--ros-args" else [argument])]
    return ["ip", "netns", "exec", namespace, "env", *environment, *command]


FAKETIME_LIBRARY_CANDIDATES = ("/usr/lib/x86_64-linux-gnu/faketime/libfaketimeMT.so.1",
                               "/usr/lib/aarch64-linux-gnu/faketime/libfaketimeMT.so.1",
                               "/usr/lib/faketime/libfaketimeMT.so.1")


def faketime_library() -> str | None:
    return next((path for path in FAKETIME_LIBRARY_CANDIDATES if Path(path).exists()), None)


def faketime_environment(offset_s: float) -> list[str]:
    """CLOCK_REALTIME of the process shifted by offset_s (libfaketime, multithreaded build); ROS time off sim time is
    CLOCK_REALTIME. The monotonic clocks are shifted by the same constant (FAKETIME_DONT_FAKE_MONOTONIC=1 would
    keep them true, but libfaketime 0.9.10 then fails Python's absolute-time sleeps with EINVAL); only their
    differences matter, within one station."""
    library = faketime_library()
    if library is None:
        raise StationError("--station-clock-offset needs libfaketime (apt-get install libfaketime)")
    return [f"LD_PRELOAD={library}", f"FAKETIME={offset_s:+.6f}",
            "FAKETIME_DONT_RESET=1", "FAKETIME_NO_CACHE=1"]


class LinkCut:
    """Sets the veth down once the run has gone `down_at` seconds (counted as --duration counts them: simulated
    time from the script's start, so a slow start-up on a loaded machine does not move the cut before the graph
    runs) and up again `down_for` wall-clock seconds later: the link is real, its outage is wall time.

    The cut also waits until the teleoperation has crossed the link for `SETTLED_S` (the robot station has
    taken commands from the master station) and the robot station's /joint_states has its readers (the replica
    and the recorder, on the topic or its batches, fic_teleop_runtime.record_batch.stream_readers; the recorder
    alone when the replica is linked to the robot in one process, node_groups.link_in_process): on a loaded
    machine the two stations' participants can take many seconds to
    discover each other (a run with a hog and a suite beside it had its first command across 13.7 s after the
    script's start, 9.7 s after its 4 s cut), and a cut before that tests nothing. How long it waited is in
    the link events (`waited_for_teleoperation_s`)."""

    SETTLED_S = 1.0

    def __init__(self, pair: StationPair, down_at: float, down_for: float, stop: threading.Event,
                 replica_linked: bool) -> None:
        self.pair, self.down_at, self.down_for, self.stop = pair, down_at, down_for, stop
        self.joint_state_readers = 1 if replica_linked else 2   # the recorder, and the replica unless linked
        self.events: dict[str, float] = {}
        self.thread = threading.Thread(target=self._run, name="link_cut", daemon=True)
        self._due_wall: float | None = None

    def command_seen(self, wall: float) -> None:
        """A teleoperation command reached the robot station (at wall-clock time `wall`)."""
        self.events.setdefault("first_command_wall", wall)

    def progress(self, elapsed: float, joint_state_readers: int) -> None:
        if elapsed < self.down_at or self.thread.is_alive() or "down_wall" in self.events:
            return
        now = time.time()
        if self._due_wall is None:
            self._due_wall = now
        first = self.events.get("first_command_wall")
        if first is None or now - first < self.SETTLED_S or joint_state_readers < self.joint_state_readers:
            return
        self.events["down_run_s"] = round(elapsed, 3)
        self.events["waited_for_teleoperation_s"] = round(now - self._due_wall, 3)
        self.thread.start()

    def _run(self) -> None:
        set_link(self.pair, up=False)
        self.events["down_wall"] = time.time()
        waited = self.events["waited_for_teleoperation_s"]
        print(f"[stations] link DOWN at {self.events['down_run_s']:.2f} s of the run"
              f"{f' (waited {waited:.1f} s for the teleoperation to cross)' if waited >= 0.1 else ''} (veth "
              f"{self.pair.master_interface} <-> {self.pair.robot_interface})", flush=True)
        # Up again even if the run is being stopped: never leave a cut link behind.
        self.stop.wait(self.down_for)
        set_link(self.pair, up=True)
        self.events["up_wall"] = time.time()
        print(f"[stations] link UP after {self.events['up_wall'] - self.events['down_wall']:.2f} s", flush=True)


def pair_from_environment(layout: StationLayout) -> StationPair:
    return StationPair(layout, os.environ.get(INSIDE_ENV, "run"))


def inside_station() -> bool:
    return bool(os.environ.get(INSIDE_ENV))


def add_arguments(parser) -> None:
    """The two-station options of scripts/run_teleop.sh."""
    group = parser.add_argument_group("two stations (root; docs/DEPLOYMENT.md)")
    group.add_argument("--two-stations", action="store_true",
                       help="run the master station and the robot station in two network namespaces joined by a "
                            "veth pair (the two_stations profile's layout and addresses), removed afterwards")
    group.add_argument("--link-down-at", type=float, default=None, metavar="T",
                       help="set the link between the stations down T seconds into the run (with --two-stations)")
    group.add_argument("--link-down-for", type=float, default=5.0, metavar="S",
                       help="... for S seconds, then up again (default 5)")
    group.add_argument("--bandwidth", default=None, metavar="RATE",
                       help="cap each direction of the link with tbf, e.g. 10mbit, 1mbit, 64kbit")
    group.add_argument("--station-clock-offset", type=float, default=0.0, metavar="SECONDS",
                       help="shift the master station's wall clock by this much (libfaketime), to test the clock "
                            "handling of the latency figures")
    group.add_argument("--print-station-commands", action="store_true",
                       help="print what to start on each of two real machines (the nodes of this run, station by "
                            "station) and exit; needs no root")
    group.add_argument("--stations-tag", default="run",
                       help="names the namespaces fic_teleop_<tag>_master/_robot (1-8 of a-z0-9; default run)")


def check_arguments(args) -> None:
    if not args.two_stations:
        if args.link_down_at is not None or args.bandwidth or args.station_clock_offset:
            raise StationError("--link-down-at, --bandwidth and --station-clock-offset need --two-stations (the "
                               "single-host channel has --blackout-window for a simulated cut)")
        return
    if args.time_mode == "lockstep":
        raise StationError("--two-stations runs in realtime only: lockstep would make the robot station's /clock and "
                           "the peer barrier cross the link")
    if not TAG_PATTERN.match(args.stations_tag):
        raise StationError(f"--stations-tag {args.stations_tag!r}: 1-8 characters of a-z and 0-9")
    if args.link_down_at is not None and (args.link_down_at < 0 or args.link_down_for <= 0
                                          or args.link_down_at + args.link_down_for >= args.duration):
        raise StationError("--link-down-at T --link-down-for S: T >= 0, S > 0 and the link back up before the end "
                           "of --duration")
    if args.bandwidth:
        parse_rate(args.bandwidth)
    if abs(args.station_clock_offset) > 3600:
        raise StationError("--station-clock-offset: at most an hour either way")
    if args.station_clock_offset and faketime_library() is None:
        raise StationError("--station-clock-offset needs libfaketime (apt-get install libfaketime)")


class InsideStation:
    """The launcher's hooks when it runs inside the robot station (FIC_TWO_STATIONS set by `run`)."""

    def __init__(self, args, run_dir: Path) -> None:
        self.args, self.run_dir = args, run_dir
        self.pair = pair_from_environment(StationLayout.from_profile(args.run_profile))
        self.fastdds_profile = run_dir / RUN_FASTDDS_PROFILE   # written by `run`, the outer process
        self.stop = threading.Event()
        self.cut: LinkCut | None = None
        self.replica_linked = False   # adapt() reads it from the graph it runs

    def adapt(self, specs: list, node_spec_class) -> None:
        adapt_graph(specs, node_spec_class, self.run_dir, self.pair.layout)
        self.replica_linked = linked_in_process(specs)
        offset = self.args.station_clock_offset
        nodes = [member for spec in specs for member in (spec.members or [spec])]   # a group's members, each
        for node in nodes:
            # A wall-clock time given to a master-station node is read on that station's clock.
            if offset and self.pair.namespace_of(node.name) == self.pair.master_namespace \
                    and "script_start_time" in node.params:
                node.params["script_start_time"] += offset
        stations = {node.name: ("master" if self.pair.namespace_of(node.name) == self.pair.master_namespace
                                else "robot") for node in nodes}
        layout = self.pair.layout
        print(f"[stations] master station ({self.pair.master_namespace}, {layout.master_address}): "
              f"{', '.join(n for n, s in stations.items() if s == 'master')}; robot station "
              f"({self.pair.robot_namespace}, {layout.robot_address}): "
              f"{', '.join(n for n, s in stations.items() if s == 'robot')}", flush=True)
        self._record({"stations": stations})

    def wrap(self, node_name: str, command: list[str]) -> list[str]:
        return wrap_command(node_name, command, self.pair, self.fastdds_profile, self.args.station_clock_offset)

    def started(self, origin_wall: float) -> None:
        self._record({"origin_wall": origin_wall})
        if self.args.link_down_at is not None:
            self.cut = LinkCut(self.pair, self.args.link_down_at, self.args.link_down_for, self.stop,
                               self.replica_linked)

    #: What the launcher's own node watches in the robot station for the cut: the commands that crossed the link.
    watched_topic = "/replica/teleop_command"

    def command_seen(self, wall: float) -> None:
        if self.cut is not None:
            self.cut.command_seen(wall)

    def progress(self, elapsed: float, joint_state_readers: int) -> None:
        if self.cut is not None:
            self.cut.progress(elapsed, joint_state_readers)

    def stopped(self) -> None:
        self.stop.set()
        if self.cut is not None:
            if self.cut.thread.is_alive():
                self.cut.thread.join(timeout=10.0)
            if "down_wall" not in self.cut.events:
                crossed = "no command crossed" if "first_command_wall" not in self.cut.events else \
                    f"the commands had not crossed for {LinkCut.SETTLED_S:g} s, or /joint_states lacked a reader,"
                print(f"[stations] warning: the link was never cut: {crossed} before the run ended "
                      "(see the logs; a longer --duration gives the stations more time to meet)", file=sys.stderr)
            self._record({"link_events": self.cut.events})

    def _record(self, values: dict) -> None:
        path = self.run_dir / "stations.json"
        record = json.loads(path.read_text()) if path.exists() else {}
        record.update(values)
        path.write_text(json.dumps(record, indent=2))


def inside_hooks(args, run_dir: Path) -> InsideStation | None:
    return InsideStation(args, run_dir) if args.two_stations and inside_station() else None


def wait_for_capture(capture: subprocess.Popen, ready: Path, timeout_s: float = 30.0) -> None:
    """Until the capture's socket is bound: a participant that announces itself (SEDP) before that leaves its
    topics unnamed in the traffic table."""
    deadline = time.monotonic() + timeout_s
    while not ready.exists():
        if capture.poll() is not None:
            raise StationError(f"the link capture exited with code {capture.returncode} (see link_capture.log)")
        if time.monotonic() > deadline:
            raise StationError(f"the link capture did not start within {timeout_s:.0f} s")
        time.sleep(0.05)


def run(argv: list[str], args, run_dir: Path) -> int:
    """The outer process: namespaces up, the launcher inside the robot station, namespaces down (always)."""
    from datetime import datetime
    try:
        check_privileges()
        check_arguments(args)
    except StationError as error:
        print(f"[stations] refused: {error}", file=sys.stderr)
        return 2
    pair = StationPair(StationLayout.from_profile(args.run_profile), args.stations_tag)
    layout = pair.layout
    try:
        for note in clear_leftovers(pair):
            print(f"[stations] {note}")
    except StationError as error:
        print(f"[stations] refused: {error}", file=sys.stderr)
        return 2
    run_dir.mkdir(parents=True, exist_ok=True)
    fastdds_profile = write_fastdds_profile(layout, run_dir / RUN_FASTDDS_PROFILE)
    record: dict = {"pair": {"master_namespace": pair.master_namespace, "robot_namespace": pair.robot_namespace,
                             "master_address": layout.master_address, "robot_address": layout.robot_address},
                    "started": datetime.now().isoformat(timespec="seconds")}
    interrupted = threading.Event()
    inner: subprocess.Popen | None = None

    def on_signal(signum, frame) -> None:
        interrupted.set()
        if inner is not None and inner.poll() is None:
            inner.send_signal(signal.SIGINT)   # the launcher stops its graph in order and finalises the bags

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    capture = None
    code = 1
    try:
        create(pair)
        print(f"[stations] namespaces {pair.master_namespace} ({layout.master_address}) and {pair.robot_namespace} "
              f"({layout.robot_address}) joined by veth {pair.master_interface} <-> {pair.robot_interface}", flush=True)
        if args.bandwidth:
            record["bandwidth"] = cap_bandwidth(pair, parse_rate(args.bandwidth))
            print(f"[stations] link capped at {args.bandwidth} each way (tbf)", flush=True)
        capture_file = run_dir / "link_capture.json"
        capture = subprocess.Popen(
            ["ip", "netns", "exec", pair.robot_namespace, sys.executable, "-m", "fic_teleop_bringup.rtps_traffic",
             "--interface", pair.robot_interface, "--out", str(capture_file),
             "--name", f"{layout.master_address}=master", "--name", f"{layout.robot_address}=robot",
             "--stamps", *layout.link_streams, "--ready", str(run_dir / "link_capture.ready")],
            stdout=open(run_dir / "link_capture.log", "wb"), stderr=subprocess.STDOUT, start_new_session=True)
        wait_for_capture(capture, run_dir / "link_capture.ready")
        environment = {**os.environ, **station_environment(fastdds_profile), INSIDE_ENV: pair.tag}
        inner = subprocess.Popen(["ip", "netns", "exec", pair.robot_namespace, sys.executable, "-m",
                                  "fic_teleop_bringup.teleop_launcher", *argv, "--out", str(run_dir)], env=environment)
        if interrupted.is_set():
            inner.send_signal(signal.SIGINT)
        code = inner.wait()
    except StationError as error:
        print(f"[stations] failed: {error}", file=sys.stderr)
        code = 1
    finally:
        if inner is not None and inner.poll() is None:
            inner.send_signal(signal.SIGINT)
            try:
                inner.wait(timeout=90)
            except subprocess.TimeoutExpired:
                inner.kill()
        if capture is not None:
            capture.send_signal(signal.SIGINT)
            try:
                capture.wait(timeout=20)
            except subprocess.TimeoutExpired:
                capture.kill()
        if namespaces() & {pair.master_namespace, pair.robot_namespace}:
            record["qdisc"] = qdisc_statistics(pair)
        for note in remove(pair):
            print(f"[stations] {note}")
        left = namespaces() & {pair.master_namespace, pair.robot_namespace}
        print("[stations] namespaces removed" if not left else f"[stations] warning: could not remove {left}",
              flush=True)
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    try:
        from fic_teleop_bringup.station_analysis import analyse_run  # reads bags: only after the run
        summary = analyse_run(run_dir, record, layout)
        print(summary)
    except Exception as error:   # the run itself is done; say why its analysis is missing
        print(f"[stations] could not analyse the run: {error!r}", file=sys.stderr)
        code = code or 1
    return code


def station_commands(args, run_dir: Path, specs: list, node_spec_class, node_command) -> str:
    """The nodes of this run, station by station, as the commands to start on two real machines. ``specs``: the
    launcher's graph of this run, ``node_command(spec)``: its command line (the launcher's own, passed in so that
    this module does not import the launcher)."""
    import shlex

    pair = StationPair(StationLayout.from_profile(args.run_profile), args.stations_tag)
    adapt_graph(specs, node_spec_class, run_dir, pair.layout)
    # On two machines each uses config/fastdds_two_stations.xml with the machines' own addresses (docs/DEPLOYMENT.md).
    environment = " ".join(f"{key}={value}" for key, value in station_environment(FASTDDS_PROFILE).items())
    lines = []
    for station, namespace in (("master", pair.master_namespace), ("robot", pair.robot_namespace)):
        address = pair.layout.master_address if station == "master" else pair.layout.robot_address
        lines.append(f"# {station} station ({address}): source scripts/env.sh; export {environment} ROS_DOMAIN_ID=<d>")
        for spec in specs:
            if pair.namespace_of(spec.name) != namespace:
                continue
            command = node_command(spec)
            if station == "master":
                command += master_remap_arguments(pair.layout)
            lines.append(shlex.join(command) + " &")
    return "\n".join(lines)
