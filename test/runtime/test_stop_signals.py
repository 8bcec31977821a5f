"""fic_teleop_runtime.stop_signals: a stop during a node's start ends the process with exit 0 and no traceback,
wherever in the start the signal's handler runs."""
from __future__ import annotations

import subprocess
import sys


def _child(body: str) -> subprocess.CompletedProcess:
    code = "from fic_teleop_runtime import stop_signals\n" \
           f"stop_signals.install()\n{body}\nprint('went on starting', flush=True)\n"
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)


def test_a_stop_while_starting_exits_through_the_finally_blocks() -> None:
    result = _child("import os, signal\ntry:\n    os.kill(os.getpid(), signal.SIGTERM)\n    import time; "
                    "time.sleep(5)\nfinally:\n    print('finally ran', flush=True)")
    assert result.returncode == 0 and "finally ran" in result.stdout and "went on" not in result.stdout
    assert "Traceback" not in result.stderr, result.stderr


def test_a_stop_whose_handler_runs_in_a_weakref_callback_still_ends_the_start() -> None:
    """Where Python cannot raise the handler's SystemExit (a weakref callback, as importlib's module-lock callback
    in a loaded suite's run), it printed "Exception ignored ... Traceback" and the start went on."""
    result = _child("import signal, weakref\nclass Held: pass\nheld = Held()\n"
                    "reference = weakref.ref(held, lambda _: stop_signals._on_signal(signal.SIGTERM, None))\n"
                    "del held")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "went on starting" not in result.stdout
    assert "Traceback" not in result.stderr and "Exception ignored" not in result.stderr, result.stderr


def test_other_unraisable_exceptions_are_still_reported() -> None:
    result = _child("import weakref\nclass Held: pass\nheld = Held()\n"
                    "reference = weakref.ref(held, lambda _: 1 / 0)\ndel held")
    assert result.returncode == 0 and "went on starting" in result.stdout
    assert "ZeroDivisionError" in result.stderr
