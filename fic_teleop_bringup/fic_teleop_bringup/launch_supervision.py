"""The launcher's hold on its nodes, and its exit code.

- The nodes die with the launcher. Each node runs in its own session (so a Ctrl-C in the terminal reaches the
  launcher alone, which stops the nodes in order and lets the recorder finish its bag); before this module, a
  SIGKILL of the launcher left all of them running (measured: 8 nodes at about 2 cores 46 s later, the bag at 15 MB
  and growing, no metadata.yaml). Now each node asks the kernel for SIGTERM when the launcher dies
  (``prctl(PR_SET_PDEATHSIG)``, kept across exec): the nodes shut down as on any SIGTERM and the recorder
  finalises its bag.
- The exit code says whether the run kept its safety figures (EXIT_CODES, also in docs/SECURITY.md): a run that
  broke a limit or lost joint states exited 0 before, and looked fine.
"""
from __future__ import annotations

import ctypes
import os
import signal
from pathlib import Path
from typing import Callable, Sequence

PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
_LIBC = ctypes.CDLL(None, use_errno=True)

EXIT_OK = 0
EXIT_NODE_FAILED = 1        # a node crashed, exited early or exited with an error; or the report failed
EXIT_REFUSED = 2            # nothing started: an option, the run folder or the domain was refused
EXIT_LIMIT_VIOLATIONS = 3   # the replica's command or the measured state broke a Panda limit (metrics.json)
EXIT_JOINT_STATES_LOST = 4  # the bag misses joint states (the run cannot be judged on the robot's own record)
EXIT_INPUT_REFUSED = 5      # the replica held the arm against a foreign robot stream or refused unsafe commands
EXIT_STARVED = 6            # every safety figure kept, but the computer did not keep real time (launch_timing.py)
EXIT_CODES = {
    EXIT_OK: "the run kept every safety figure",
    EXIT_NODE_FAILED: "a node crashed, exited early or with an error, or the report failed",
    EXIT_REFUSED: "refused before anything started (an option, the run folder, the domain)",
    EXIT_LIMIT_VIOLATIONS: "limit violations (torque, torque rate, joint speed or position, TCP speed), or the "
                           "robot's velocity reflex stopped the arm",
    EXIT_JOINT_STATES_LOST: "joint states lost in the bag",
    EXIT_INPUT_REFUSED: "the replica held the arm or refused commands (a second publisher, stamps going back, "
                        "commands outside the authority bounds)",
    EXIT_STARVED: "the machine was starved: the run did not keep real time (real-time factor, loop rates or the "
                  "replica's own loop out of bounds), so its tracking figures say little about the controller",
}
# A node ended by the launcher's own SIGINT (or by rclpy after it) exits 0, -2 or 130.
CLEAN_NODE_CODES = (0, -signal.SIGINT, 128 + signal.SIGINT, None)


def die_with_launcher(launcher_pid: int, then: Callable[[], None] | None = None,
                      block_stop_signals: bool = True) -> Callable[[], None]:
    """A ``preexec_fn``: the child gets SIGTERM when the launcher's starting thread ends (the main thread here:
    Graph.start runs there), then runs ``then`` (the niceness). If the launcher died between fork and here, the
    child leaves at once instead of running unsupervised.

    ``block_stop_signals``: the child starts with SIGINT and SIGTERM blocked (kept across exec); our nodes unblock
    them once their handlers are in (fic_teleop_runtime.stop_signals), so a stop during the interpreter's start waits a
    moment instead of killing the node mid-import. Only for our own executables: a wrapper that does not unblock
    them (``ros2 run``) would never see a stop."""

    def apply() -> None:
        if block_stop_signals:
            signal.pthread_sigmask(signal.SIG_BLOCK, (signal.SIGINT, signal.SIGTERM))
        _LIBC.prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
        if os.getppid() != launcher_pid:
            os._exit(EXIT_NODE_FAILED)
        if then is not None:
            then()
    return apply


def failed_nodes(codes: dict[str, int | None]) -> dict[str, int | None]:
    return {name: code for name, code in codes.items() if code not in CLEAN_NODE_CODES}


def diagnostics_records(bag: Path, wanted: dict[str, str]) -> dict[str, dict[str, str]]:
    """The last /diagnostics values of each status named in ``wanted`` (status name -> a key its record must hold:
    the replica's input-authority figures, input_guard.py; the robot's reflex, velocity_reflex.py), as recorded in
    the bag; a status the bag has none of is absent (a torn bag is read up to its last whole chunk)."""
    from mcap_ros2.reader import read_ros2_messages

    files = sorted(bag.glob("*.mcap")) if bag.is_dir() else [bag]
    last: dict[str, dict[str, str]] = {}
    try:
        for file in files:
            for message in read_ros2_messages(str(file), topics=["/diagnostics"]):
                for status in message.ros_msg.status:
                    if status.name in wanted:
                        values = {item.key: item.value for item in status.values}
                        if wanted[status.name] in values:
                            last[status.name] = values
    except Exception:  # noqa: BLE001 - a torn or foreign bag: the verdict goes on without these figures
        return last
    return last


REPLICA_STOPPED_LINE = "replica stopped: "   # fic_teleop_replica.replica_node.STOPPED_LINE (not imported here)


def replica_stop_counters(log_dir: Path) -> dict[str, str] | None:
    """The replica's statistics as its last log line gave them at its stop (its cumulative tick counters, the same
    values as its /diagnostics record); None without that line (the replica killed, another replica)."""
    import ast

    log = log_dir / "replica.log"
    try:
        lines = log.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return None
    for line in reversed(lines):
        if REPLICA_STOPPED_LINE in line:
            try:
                values = ast.literal_eval(line.split(REPLICA_STOPPED_LINE, 1)[1].strip())
            except (ValueError, SyntaxError):
                return None
            return {str(key): str(value) for key, value in values.items()} if isinstance(values, dict) else None
    return None


def fill_limit_counters(metrics: dict, log_dir: Path) -> bool:
    """A report without limit counts (a recorder starved before it took any of the replica's): the replica's own
    counters from its stop line, into ``metrics`` with ``limit_counters_source`` saying so. True if filled."""
    if metrics.get("limit_violations") is not None:
        return False
    counters = replica_stop_counters(log_dir)
    try:
        violations, shaped, ticks = (int(counters[key]) for key in ("violation_ticks", "shaped_ticks", "ticks"))
    except (TypeError, KeyError, ValueError):
        return False
    metrics.update(limit_violations=violations, limit_shaped_ticks=shaped,
                   limit_counters_source=f"the replica's log at its stop ({ticks} control ticks)")
    (metrics.get("not_measured") or {}).pop("limit_violations", None)
    return True


#: The /diagnostics records the safety verdict reads (status name -> a key its record must hold): the replica's
#: input-authority figures (input_guard.py), the robot's velocity reflex (velocity_reflex.py).
SAFETY_RECORDS = {"replica": "input_safe_hold", "robot_sim": "reflex"}


def safety_verdict(metrics: dict | None, node_codes: dict[str, int | None], early_exits: list[str],
                   report_failed: bool, bag: Path | None = None, killed_at_stop: Sequence[str] = (),
                   starved: bool = False, records: dict[str, dict[str, str]] | None = None) -> tuple[int, list[str]]:
    """The launcher's exit code and one reason per broken figure, worst first: a failed node, limit violations,
    lost joint states, refused robot-side input. ``metrics``: the report's metrics.json (None: no report);
    ``bag``: the run's bag, for the replica's input-authority record and the robot's velocity reflex.

    ``killed_at_stop``: the nodes the launcher killed because they had not stopped on SIGINT in time. On a machine
    the timing verdict found ``starved`` that is the starvation's doing (measured: the device and master under a 40 %
    CPU quota still running 15 s after SIGINT), not a crash: no safety reason, the timing verdict names the kill.
    On a machine that kept real time (or a lockstep run, which is not judged) a node that hangs at its stop is a
    failed node. ``records``: the bag's SAFETY_RECORDS when the caller has read them already (run_bag.py); None:
    read from ``bag`` here."""
    reasons: list[tuple[int, str]] = []
    killed = [name for name in killed_at_stop if name in node_codes]
    failed = failed_nodes({name: code for name, code in node_codes.items() if name not in killed})
    if failed:
        reasons.append((EXIT_NODE_FAILED, "nodes exited with errors: "
                        + ", ".join(f"{name} ({code})" for name, code in failed.items())))
    if killed and not starved:
        reasons.append((EXIT_NODE_FAILED, f"nodes killed at the stop, still running long after SIGINT on a machine "
                                          f"that kept real time: {', '.join(killed)}"))
    if early_exits:
        reasons.append((EXIT_NODE_FAILED, f"nodes exited before the end of the run: {', '.join(early_exits)}"))
    if report_failed:
        reasons.append((EXIT_NODE_FAILED, "the report failed"))
    if metrics:
        violations = metrics.get("limit_violations")
        if violations:
            reasons.append((EXIT_LIMIT_VIOLATIONS, f"{violations} limit-violation ticks"))
        dropped = metrics.get("dropped_joint_states")
        if dropped:
            reasons.append((EXIT_JOINT_STATES_LOST, f"{dropped} joint states lost in the bag"))
    if records is None:
        records = diagnostics_records(bag, SAFETY_RECORDS) if bag is not None and bag.exists() else {}
    reflex = records.get("robot_sim", {}).get("reflex")
    if reflex:
        reasons.append((EXIT_LIMIT_VIOLATIONS, f"the robot stopped the arm: {reflex}"))
    record = records.get("replica")
    if record:
        if record.get("input_safe_hold", "no") != "no":
            reasons.append((EXIT_INPUT_REFUSED, f"the replica went into its safe hold: {record['input_safe_hold']}"))
        refused, clamped = int(record.get("refused_teleop_commands", 0)), int(record.get("clamped_teleop_commands", 0))
        if refused or clamped:
            last = f" (the last: {record['last_refusal']})" if refused and record.get("last_refusal") else ""
            reasons.append((EXIT_INPUT_REFUSED, f"the replica refused {refused} teleoperation commands{last} and "
                                                f"clamped {clamped} onto its workspace"))
    if not reasons:
        return EXIT_OK, []
    return min(code for code, _ in reasons), [text for _, text in reasons]
