"""One ``main()`` for every node: start, spin until stopped, refuse bad input in one line, clean up.

What each node's main() did by hand before, six times over and not alike (only the replica caught a malformed
params file; the fd adapter kept rclpy's own signal handlers):

- ``rclpy.init`` with our stop-signal handlers (stop_signals.py) instead of rclpy's, so a SIGINT or SIGTERM at any
  moment only asks the spin loop to stop, and the node is destroyed before the context goes.
- A bad start is refused in one FATAL line and exit code ``EXIT_REFUSED`` (2), the launcher's "refused before
  anything started" (fic_teleop_bringup/launch_supervision.py): a malformed params file or ROS argument (RCLError from
  rcl's parser), a parameter out of range, of the wrong type or unknown (ParameterException from rclpy, FicInputError
  from our checks), and whatever else the node names in ``refusals`` (an existing bag folder, a taken port).
  No traceback: the line says what to fix. A robot left without commands holds the arm by its own watchdog.
- A clean stop exits 0, which the launcher counts as clean (CLEAN_NODE_CODES there); anything else that escapes
  is a crash, with its traceback and exit code 1 (EXIT_NODE_FAILED).
"""
from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TypeVar

import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from fic_core.errors import FicInputError
from fic_teleop_runtime import record_batch, stop_signals
from fic_teleop_runtime.parameters import START_ARGUMENTS
from fic_teleop_runtime.spin import SLICE, spin_until_shutdown

EXIT_NODE_FAILED = 1  # launch_supervision.py's "a node crashed": a thread it needed died (stop_signals.fail)
EXIT_REFUSED = 2  # fic_teleop_bringup/launch_supervision.py: EXIT_REFUSED, "refused before anything started"
#: What a bad start raises: a parameter the node's schema refuses, a value fic_core refuses.
INPUT_ERRORS: tuple[type[BaseException], ...] = (FicInputError, ParameterException)

N = TypeVar("N", bound=Node)


def refuse(name: str, reason: object) -> None:
    """The one FATAL line of a refused start, then exit ``EXIT_REFUSED``. Not the node's logger: there may be no
    node (or no valid context) yet."""
    text = " ".join(str(reason).split())  # one line, whatever the exception's text holds
    rclpy.logging.get_logger(name).fatal(f"cannot start: {text}")
    raise SystemExit(EXIT_REFUSED)


@dataclass(frozen=True)
class NodeEntry:
    """What it takes to run one node: ``make(**options)`` builds it (``options``: rclpy Node keywords, e.g. the
    ``cli_args`` of a node that shares its process, node_group.py); the rest as for ``run_node``."""

    make: Callable[..., Node]
    name: str
    refusals: tuple[type[BaseException], ...] = ()
    stopped: Callable[[Node], None] | None = None
    slice_s: float = SLICE
    follow_sim_time: bool = True
    switch_interval: float | None = None  # [s] the interpreter's thread switch interval (sys.setswitchinterval)
    started: Callable[[Node], None] | None = None   # once every node of the process is built, before the spin


def run_node(make_node: Callable[[], N], name: str, args: Sequence[str] | None = None, *,
             refusals: tuple[type[BaseException], ...] = (), stopped: Callable[[N], None] | None = None,
             slice_s: float = SLICE, follow_sim_time: bool = True) -> None:
    """Run the node ``make_node()`` builds until SIGINT, SIGTERM or an external shutdown.

    ``name``: the logger of the refusal line. ``refusals``: more exception types that mean a bad start.
    ``stopped(node)``: runs after the spin, before the node is destroyed, with the stop signals ignored (a
    second Ctrl-C must not cut a bag's footer or the final statistics short); log through
    ``rclpy.logging.get_logger``, as after a signal the context may be gone and /rosout with it.
    ``slice_s``, ``follow_sim_time``: see spin.spin_until_shutdown."""
    run_entries([NodeEntry(make_node, name, refusals, stopped, slice_s, follow_sim_time)], args)


def run_entry(entry: NodeEntry, args: Sequence[str] | None = None) -> None:
    """A node module's ``main()``: its one entry in a process of its own."""
    run_entries([entry], args)


def run_entries(entries: Sequence[NodeEntry], args: Sequence[str] | None = None,
                node_arguments: Sequence[Sequence[str]] | None = None) -> None:
    """Run the nodes of ``entries`` in one process, on one executor, until stopped (``run_node`` for each).

    ``node_arguments[i]``: the ``--ros-args ...`` of the i-th node alone (its name, params files, remaps), when
    several share the process; None: the process's own arguments are the one node's. A refusal of any node refuses
    the process. On the way out each node's ``stopped`` runs, last started first, then the nodes are destroyed."""
    intervals = [entry.switch_interval for entry in entries if entry.switch_interval is not None]
    if intervals:
        sys.setswitchinterval(min(intervals))
    stop_signals.install()
    try:
        rclpy.init(args=list(args) if args is not None else None, signal_handler_options=SignalHandlerOptions.NO)
    except RCLError as exc:  # e.g. a malformed --params-file
        refuse(entries[0].name, f"bad ROS arguments or parameter file: {exc}")
    nodes: list[tuple[NodeEntry, Node]] = []
    process_arguments = tuple(sys.argv if args is None else args)
    try:
        for index, entry in enumerate(entries):
            options = {} if node_arguments is None else {"cli_args": list(node_arguments[index])}
            # What the node's parameter declaration checks the given keys against (parameters.declare).
            START_ARGUMENTS.set(process_arguments + tuple(options.get("cli_args", ())))
            try:
                nodes.append((entry, entry.make(**options)))
            except RCLError as exc:  # a member's own malformed --params-file
                refuse(entry.name, f"bad ROS arguments or parameter file: {exc}")
            except (*INPUT_ERRORS, *entry.refusals) as exc:
                refuse(entry.name, exc)
        for entry, node in nodes:   # e.g. the robot's physics: not while a neighbour is still being built
            if entry.started is not None:
                entry.started(node)
        spin_until_shutdown([node for _, node in nodes], min(entry.slice_s for entry in entries),
                            any(entry.follow_sim_time for entry in entries))
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        stop_signals.ignore()
        for entry, node in reversed(nodes):
            if entry.stopped is not None:
                entry.stopped(node)
            record_batch.flush_node(node)   # its publishers' last batches to the recorder (record_batch.py)
            node.destroy_node()
        rclpy.try_shutdown()
    if stop_signals.failed():
        raise SystemExit(EXIT_NODE_FAILED)
