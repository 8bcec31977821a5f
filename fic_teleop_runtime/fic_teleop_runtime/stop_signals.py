"""SIGINT and SIGTERM end a node cleanly at any moment: exit 0, no traceback, no FATAL line.

Measured before: a Ctrl-C crashed haptic_device_node in its spin loop (a pybind11 conversion error, exit 1, 1 of 2
runs), "[FATAL] Exception in 'timers' callback" was printed at shutdown 19 times in 17 runs, and a signal during
the imports (1-4 s of them on a loaded 2-core machine) gave a KeyboardInterrupt traceback or a death by SIGTERM.
Two causes, two answers:

- rclpy's own signal handler shuts the context down at once, under callbacks that are still running (a timer's
  publish then raises on the invalid context). The nodes call ``rclpy.init`` with ``SignalHandlerOptions.NO`` and
  these handlers instead: once the node spins (``running()``), a signal only sets a flag that the spin loop reads
  between slices; the node is then destroyed and only then the context shut down.
- Before the node spins there is nothing to finish: a signal then ends the process with ``SystemExit(0)``, which
  runs the ``finally`` blocks on its way out. To cover the interpreter's own start, before any of our code runs,
  the launcher starts each node with SIGINT and SIGTERM blocked (fic_teleop_bringup/launch_supervision.py); a blocked
  signal waits, and ``install()`` (run when fic_teleop_runtime is imported, first thing in each node package) installs
  these handlers and unblocks them, so a signal sent at any moment is handled here. A node started by hand gets
  them when ``run_node`` calls ``install()``. Where that SystemExit cannot propagate (an uncaught exception a C
  extension makes of it, or an "Exception ignored" in a weakref callback or a destructor), the process exits 0
  right there (``_on_uncaught``, ``_on_unraisable``).
"""
from __future__ import annotations

import os
import signal
import sys

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_state = {"requested": False, "running": False, "installed": False, "failed": False}


def _on_signal(signum: int, frame) -> None:  # noqa: ARG001 - signal handler signature
    _state["requested"] = True
    if not _state["running"]:
        raise SystemExit(0)  # still starting: nothing to finish, leave through the finally blocks


def _exit_if_stopped_while_starting() -> None:
    """A stop came while the node was starting and its SystemExit went astray: exit 0 now, output flushed."""
    if _state["requested"] and not _state["running"]:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)


def _on_uncaught(kind, value, traceback) -> None:
    """An exception nobody caught, after a stop came during the start: the stop's doing, exit 0 without a
    traceback. A signal inside a C extension's initialisation (measured: SIGTERM during ``import mujoco`` on a
    loaded machine) turns our SystemExit into "ImportError: initialization failed" on its way up."""
    _exit_if_stopped_while_starting()
    _previous_hook(kind, value, traceback)


def _on_unraisable(unraisable) -> None:
    """An exception Python cannot raise where it happened (a weakref callback, a destructor) is printed as "Exception
    ignored in ..." with a traceback, and the code goes on. Our SystemExit of a stop during the start can land there
    (measured: in importlib's module-lock callback, on a loaded machine): then the stop's doing, exit 0 at once,
    without the traceback and without starting the node."""
    if isinstance(unraisable.exc_value, SystemExit):
        _exit_if_stopped_while_starting()
    _previous_unraisable_hook(unraisable)


_previous_hook = sys.excepthook
_previous_unraisable_hook = sys.unraisablehook


def install() -> None:
    """Take SIGINT and SIGTERM (idempotent), then unblock them: a signal that waited while blocked lands here."""
    if not _state["installed"]:
        for signum in STOP_SIGNALS:
            signal.signal(signum, _on_signal)
        sys.excepthook = _on_uncaught
        sys.unraisablehook = _on_unraisable
        _state["installed"] = True
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)


def install_if_blocked() -> None:
    """``install()`` if this process was started with the stop signals blocked (by the launcher), else nothing: an
    import of the package in a test process or a tool leaves its signal handling alone."""
    if set(STOP_SIGNALS) <= signal.pthread_sigmask(signal.SIG_BLOCK, []):
        install()


def running() -> None:
    """The node spins from now on: a signal only asks it to stop (``requested``)."""
    _state["running"] = True


def requested() -> bool:
    return _state["requested"]


def fail() -> None:
    """A thread the node cannot run without has died (it said why): stop as a signal would, then exit 1 (node_main),
    so that the launcher sees a crash instead of a node that runs on and does nothing."""
    _state["failed"] = _state["requested"] = True


def failed() -> bool:
    return _state["failed"]


def ignore() -> None:
    """From now on a stop signal does nothing: the node is cleaning up (a recorder finishing its bag), and a second
    Ctrl-C must not cut that short."""
    for signum in STOP_SIGNALS:
        signal.signal(signum, signal.SIG_IGN)
