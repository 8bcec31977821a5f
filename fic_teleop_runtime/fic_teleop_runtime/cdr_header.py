"""Read a message's header stamp straight out of its CDR bytes, without deserialising it.

The channel forwards raw bytes of any message type, yet wants each message's own stamp (for the statistics and
for fic_teleop_msgs/ChannelDelivery). For every message whose first field is std_msgs/Header (and for a bare
Header), the serialized form starts with:

    bytes 0-3   encapsulation header: 0x00 0x01 = CDR little endian, 0x00 0x00 = CDR big endian, then 2 options
    bytes 4-7   header.stamp.sec      int32   (offset 0 of the CDR body: already aligned)
    bytes 8-11  header.stamp.nanosec  uint32

so two integers at fixed offsets are the whole job: ``struct`` reads them in well under a microsecond.
"""
from __future__ import annotations

import struct

_LITTLE = struct.Struct("<iI")
_BIG = struct.Struct(">iI")
_ENCAPSULATION_LITTLE = (0x00, 0x01)
_ENCAPSULATION_BIG = (0x00, 0x00)
_NANOSECONDS = 1_000_000_000


def header_stamp(data: bytes) -> tuple[int, int] | None:
    """(sec, nanosec) of the leading header stamp, or None if the bytes cannot hold one (too short, an
    encapsulation other than plain CDR, or a nanosec field out of range, which no valid stamp has)."""
    if len(data) < 12:
        return None
    kind = (data[0], data[1])
    if kind == _ENCAPSULATION_LITTLE:
        sec, nanosec = _LITTLE.unpack_from(data, 4)
    elif kind == _ENCAPSULATION_BIG:
        sec, nanosec = _BIG.unpack_from(data, 4)
    else:
        return None
    if nanosec >= _NANOSECONDS:
        return None
    return sec, nanosec


def stamp_seconds(stamp: tuple[int, int]) -> float:
    return stamp[0] + stamp[1] * 1e-9
