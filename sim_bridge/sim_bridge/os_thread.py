"""Give the calling thread a name the operating system shows (top -H, /proc/<pid>/task/<tid>/comm).

Python's thread names stay inside Python; a scheduler policy set from outside
(fic_teleop_bringup/realtime_scheduling.py) can only pick a thread by its OS name. Linux only (prctl PR_SET_NAME);
elsewhere this does nothing.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import sys

PR_SET_NAME = 15
OS_NAME_LIMIT = 15  # bytes, without the terminating zero


def name_os_thread(name: str) -> bool:
    """Name the calling thread ``name`` (cut to 15 bytes). True if the OS took it."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        return libc.prctl(PR_SET_NAME, name.encode()[:OS_NAME_LIMIT], 0, 0, 0) == 0
    except OSError:
        return False
