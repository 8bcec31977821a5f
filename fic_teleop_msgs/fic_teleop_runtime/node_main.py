"""One ``main()`` for every node: start, spin until stopped, refuse bad input in one line, clean up.

What each node's main() did by hand before, six times over and not alike (only the replica caught a malformed
params file; the fd adapter kept rclpy's own signal handlers):

- ``rclpy.init`` with our stop-signal handlers (stop_signals.py) instead of rclpy's, so a SIGINT or SIGTERM at any
  moment only asks the spin loop to stop, and the node is destroyed before the context goes.
- A bad start is refused in one FATAL line and exit code ``EXIT_REFUSED`` (2), the launcher's "refused before
  anything started" (scripts/launch_supervision.py): a malformed params file or ROS argument (RCLError from rcl's
  parser), a parameter out of range, of the wrong type or unknown (ParameterException from rclpy, FicInputError
  from our checks), and whatever else the node names in ``refusals`` (an existing bag folder, a taken port).
  No traceback: the line says what to fix. A robot left without commands holds the arm by its own watchdog.
- A clean stop exits 0, which the launcher counts as clean (CLEAN_NODE_CODES there); anything else that escapes
  is a crash, with its traceback and exit code 1 (EXIT_NODE_FAILED).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TypeVar

import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from fic_core.errors import FicInputError
from fic_teleop_runtime import stop_signals
from fic_teleop_runtime.spin import SLICE, spin_until_shutdown

EXIT_REFUSED = 2  # scripts/launch_supervision.py: EXIT_REFUSED, "refused before anything started"
#: What a bad start raises: a parameter the node's schema refuses, a value fic_core refuses.
INPUT_ERRORS: tuple[type[BaseException], ...] = (FicInputError, ParameterException)

N = TypeVar("N", bound=Node)


def refuse(name: str, reason: object) -> None:
    """The one FATAL line of a refused start, then exit ``EXIT_REFUSED``. Not the node's logger: there may be no
    node (or no valid context) yet."""
    text = " ".join(str(reason).split())  # one line, whatever the exception's text holds
    rclpy.logging.get_logger(name).fatal(f"cannot start: {text}")
    raise SystemExit(EXIT_REFUSED)


def run_node(make_node: Callable[[], N], name: str, args: Sequence[str] | None = None, *,
             refusals: tuple[type[BaseException], ...] = (), stopped: Callable[[N], None] | None = None,
             slice_s: float = SLICE, follow_sim_time: bool = True) -> None:
    """Run the node ``make_node()`` builds until SIGINT, SIGTERM or an external shutdown.

    ``name``: the logger of the refusal line. ``refusals``: more exception types that mean a bad start.
    ``stopped(node)``: runs after the spin, before the node is destroyed, with the stop signals ignored (a
    second Ctrl-C must not cut a bag's footer or the final statistics short); log through
    ``rclpy.logging.get_logger``, as after a signal the context may be gone and /rosout with it.
    ``slice_s``, ``follow_sim_time``: see spin.spin_until_shutdown."""
    stop_signals.install()
    try:
        rclpy.init(args=list(args) if args is not None else None, signal_handler_options=SignalHandlerOptions.NO)
    except RCLError as exc:  # e.g. a malformed --params-file
        refuse(name, f"bad ROS arguments or parameter file: {exc}")
    node: N | None = None
    try:
        try:
            node = make_node()
        except (*INPUT_ERRORS, *refusals) as exc:
            refuse(name, exc)
        spin_until_shutdown(node, slice_s, follow_sim_time)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        stop_signals.ignore()
        if node is not None:
            if stopped is not None:
                stopped(node)
            node.destroy_node()
        rclpy.try_shutdown()
