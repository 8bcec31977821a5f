"""The joint state a torque command was computed on, carried in the command itself.

ros2_control's effort command is a std_msgs/Float64MultiArray: no header, no stamp. A robot that applies every
command as it comes cannot tell a torque computed on the state of a millisecond ago from one computed on a state a
starved replica took 150 ms ago, and a stale torque on a moving arm is what swung the simulated arm over its base
(docs/RESULTS.md, "Starvation"). So the replica names the state's stamp in the array's layout: one dimension,
"joints", of the command's size, whose label carries the stamp in nanoseconds. The layout is metadata a forward
command controller does not read, so a real driver takes the command as before; the simulated robot reads the stamp
and never applies a torque computed on a state older than its command_state_timeout (docs/SECURITY.md).
"""
from __future__ import annotations

PREFIX = "joints@state_stamp_ns="


def label(stamp_ns: int) -> str:
    """The layout label of a command computed on the joint state stamped ``stamp_ns``."""
    return f"{PREFIX}{int(stamp_ns)}"


def stamp_ns(text: str) -> int | None:
    """The state stamp a label carries, None if it carries none (a command from another writer, or unstamped)."""
    if not text.startswith(PREFIX):
        return None
    digits = text[len(PREFIX):]
    return int(digits) if digits.isdigit() else None
