"""builtin_interfaces/Time <-> seconds and nanoseconds: the one conversion every node needs for header stamps."""
from __future__ import annotations

from builtin_interfaces.msg import Time

NANOSECONDS = 1_000_000_000


def nanoseconds(stamp: Time) -> int:
    """A stamp as integer nanoseconds (exact: no float rounding of the 1 kHz stamps)."""
    return stamp.sec * NANOSECONDS + stamp.nanosec


def seconds(stamp: Time) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def time_message(nanoseconds_since_epoch: int) -> Time:
    """Integer nanoseconds -> builtin_interfaces/Time."""
    sec, nanosec = divmod(int(nanoseconds_since_epoch), NANOSECONDS)
    return Time(sec=sec, nanosec=nanosec)

