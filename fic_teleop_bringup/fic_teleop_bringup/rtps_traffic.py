"""What crosses the link between the two stations, topic by topic: a packet capture of RTPS on one interface.

Run inside a station's network namespace (``ip netns exec <ns> python -m fic_teleop_bringup.rtps_traffic
--interface <if> --out <file>``) until SIGINT/SIGTERM. It opens an AF_PACKET socket on the interface (root), reassembles
IPv4 fragments, reads the RTPS header and submessages of each UDP datagram (DDSI-RTPS 2.x, section 9.4) and charges
the datagram's bytes on the wire (IPv4 header and all) to the DDS entity each submessage belongs to: the writer of
a DATA, DATA_FRAG, HEARTBEAT or GAP; for an ACKNACK or NACK_FRAG the remote writer it acknowledges. The header
bytes of a datagram (IP, UDP, RTPS header, INFO_TS/INFO_DST) are shared equally among its entity submessages, so
the per-topic bytes add up to the interface's total.

Topic names come from the discovery traffic itself: every SEDP publication/subscription announcement (the
builtin writers 0x000003c2 / 0x000004c2) carries PID_ENDPOINT_GUID and PID_TOPIC_NAME, so the capture must start
before the stations' nodes do. ROS 2 topics appear as DDS topics ``rt/<name>``; the names written out are the ROS
ones. The builtin entities are named by their role: SPDP (participant announcements), SEDP (endpoint
announcements), WLP (liveliness), type lookup.

Output (JSON, written at exit): per direction ("a->b" by IPv4 source and destination) and per second of wall time
(int(time.time())), bytes and RTPS DATA submessages per topic; see `summarise` for windows. For the topics given
with --stamps (header-stamped messages), also each sample's header stamp and the kernel's timestamp of the frame
on this interface (SO_TIMESTAMPNS, this station's clock): when the message was on the wire, to set against the
other station's clock (station_analysis.py, "clocks").
"""
from __future__ import annotations

import argparse
import errno
import json
import signal
import socket
import struct
import sys
import time
from collections import defaultdict
from pathlib import Path

ETH_P_ALL = 0x0003
ETH_P_IP = 0x0800
RTPS_MAGIC = b"RTPS"

# Submessage ids (DDSI-RTPS 2.5 table 8.13).
ACKNACK, HEARTBEAT, GAP, INFO_TS, INFO_SRC, INFO_DST, NACK_FRAG, HEARTBEAT_FRAG, DATA, DATA_FRAG = (
    0x06, 0x07, 0x08, 0x09, 0x0C, 0x0E, 0x12, 0x13, 0x15, 0x16)
WRITER_SIDE = {DATA, DATA_FRAG, HEARTBEAT, GAP, HEARTBEAT_FRAG}   # the submessage names its writer
READER_SIDE = {ACKNACK, NACK_FRAG}                                # the reader names the remote writer it acks

# Builtin endpoints (DDSI-RTPS 2.5 table 9.2): writer and reader ids, both named.
BUILTIN = {
    0x000100C2: "discovery: SPDP participant announcements", 0x000100C7: "discovery: SPDP participant announcements",
    0x000003C2: "discovery: SEDP publications", 0x000003C7: "discovery: SEDP publications",
    0x000004C2: "discovery: SEDP subscriptions", 0x000004C7: "discovery: SEDP subscriptions",
    0x000200C2: "liveliness: WLP participant messages", 0x000200C7: "liveliness: WLP participant messages",
    0x000300C3: "type lookup", 0x000300C4: "type lookup", 0x000301C3: "type lookup", 0x000301C4: "type lookup",
}
SEDP_ANNOUNCERS = (0x000003C2, 0x000004C2)
PID_SENTINEL, PID_TOPIC_NAME, PID_ENDPOINT_GUID = 0x0001, 0x0005, 0x005A
SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35)   # Linux: SCM_TIMESTAMPNS has the same value


def ros_topic(dds_name: str) -> str:
    """The ROS name of a DDS topic: rt/ (topics), rq/ and rr/ (services) are the ROS 2 prefixes."""
    for prefix, kind in (("rt/", ""), ("rq/", " (service request)"), ("rr/", " (service reply)")):
        if dds_name.startswith(prefix):
            return "/" + dds_name[len(prefix):] + kind
    return dds_name   # DDS-level topics such as ros_discovery_info (the ROS graph cache)


def parameter_list(payload: bytes) -> dict[int, bytes]:
    """PID -> value of a serialized ParameterList (PL_CDR_LE 0x0003 / PL_CDR_BE 0x0002 encapsulation)."""
    if len(payload) < 4 or payload[0] != 0 or payload[1] not in (2, 3):
        return {}
    order = "<" if payload[1] == 3 else ">"
    values: dict[int, bytes] = {}
    offset = 4
    while offset + 4 <= len(payload):
        pid, length = struct.unpack_from(order + "HH", payload, offset)
        offset += 4
        if pid == PID_SENTINEL:
            break
        values.setdefault(pid & 0x3FFF, payload[offset:offset + length])
        offset += length
    return values


def sedp_endpoint(payload: bytes) -> tuple[bytes, str] | None:
    """(endpoint GUID, ROS topic name) of a SEDP announcement, if both are in it."""
    values = parameter_list(payload)
    guid, name = values.get(PID_ENDPOINT_GUID), values.get(PID_TOPIC_NAME)
    if not guid or len(guid) < 16 or not name or len(name) < 4:
        return None
    order = "<" if payload[1] == 3 else ">"
    (length,) = struct.unpack_from(order + "I", name, 0)
    return bytes(guid[:16]), ros_topic(name[4:4 + length].rstrip(b"\0").decode("utf-8", "replace"))


class RtpsAccounting:
    """Bytes and DATA counts per (direction, topic, second), learning endpoint names from SEDP as it goes."""

    def __init__(self, stamped_topics: set[str] | None = None) -> None:
        self.stamped_topics = stamped_topics or set()
        self.wire_times: dict[str, list[tuple[int, float]]] = defaultdict(list)   # topic -> (stamp ns, wire s)
        self.names: dict[bytes, str] = {}            # endpoint GUID (prefix + entity id) -> topic
        self.bytes: dict[tuple[str, str, int], float] = defaultdict(float)
        self.samples: dict[tuple[str, str, int], int] = defaultdict(int)
        self.unnamed: set[str] = set()

    def entity_name(self, prefix: bytes, entity: int) -> str:
        if entity in BUILTIN:
            return BUILTIN[entity]
        guid = prefix + struct.pack(">I", entity)
        if guid in self.names:
            return self.names[guid]
        label = f"unnamed endpoint {prefix.hex()}:{entity:08x}"
        self.unnamed.add(label)
        return "unnamed endpoints (discovered before the capture started)"

    def datagram(self, direction: str, second: int, wire_bytes: int, rtps: bytes, wire_time: float = 0.0) -> None:
        if len(rtps) < 20 or rtps[:4] != RTPS_MAGIC:
            self.bytes[(direction, "not RTPS", second)] += wire_bytes
            return
        source = rtps[8:20]
        destination = b"\0" * 12
        offset = 20
        charged: list[tuple[str, int, bool]] = []   # (entity name, submessage bytes, is a DATA)
        overhead = 20
        while offset + 4 <= len(rtps):
            kind, flags = rtps[offset], rtps[offset + 1]
            order = "<" if flags & 1 else ">"
            (length,) = struct.unpack_from(order + "H", rtps, offset + 2)
            body_start = offset + 4
            body_end = len(rtps) if length == 0 and kind not in (INFO_TS, 0x01) else body_start + length
            body = rtps[body_start:body_end]
            size = body_end - offset
            if kind == INFO_DST and len(body) >= 12:
                destination = body[:12]
                overhead += size
            elif kind == INFO_SRC and len(body) >= 20:
                source = body[8:20]
                overhead += size
            elif kind in WRITER_SIDE and len(body) >= 8:
                reader, writer = struct.unpack_from(">II", body, 0 if kind in (HEARTBEAT, GAP, HEARTBEAT_FRAG) else 4)
                name = self.entity_name(source, writer)
                charged.append((name, size, kind in (DATA, DATA_FRAG)))
                if kind == DATA and writer in SEDP_ANNOUNCERS:
                    self._learn(body, flags)
                elif kind == DATA and name in self.stamped_topics:
                    stamp = self._header_stamp(body, flags)
                    if stamp is not None and len(self.wire_times[name]) < 200_000:
                        self.wire_times[name].append((stamp, wire_time))
            elif kind in READER_SIDE and len(body) >= 8:
                reader, writer = struct.unpack_from(">II", body, 0)
                remote = destination if destination != b"\0" * 12 else source
                charged.append((self.entity_name(remote, writer), size, False))
            else:
                overhead += size
            offset = body_end
        header = wire_bytes - sum(size for _, size, _ in charged)   # IP/UDP/RTPS headers, INFO_* submessages
        if not charged:
            self.bytes[(direction, "RTPS without entity submessages", second)] += wire_bytes
            return
        for name, size, is_data in charged:
            self.bytes[(direction, name, second)] += size + header / len(charged)
            if is_data:
                self.samples[(direction, name, second)] += 1

    @staticmethod
    def _payload_start(body: bytes, flags: int) -> int:
        """Where a DATA's serialized payload begins: after the fixed part and any inline QoS."""
        order = "<" if flags & 1 else ">"
        (to_inline_qos,) = struct.unpack_from(order + "H", body, 2)
        start = 4 + to_inline_qos
        if flags & 0x02:
            while start + 4 <= len(body):
                pid, length = struct.unpack_from(order + "HH", body, start)
                start += 4 + length
                if pid == PID_SENTINEL:
                    break
        return start

    def _header_stamp(self, body: bytes, flags: int) -> int | None:
        """The std_msgs/Header stamp [ns] at the start of a ROS message's CDR (after its 4-byte encapsulation)."""
        if not flags & 0x04:
            return None
        start = self._payload_start(body, flags)
        if start + 12 > len(body) or body[start] != 0:
            return None
        order = "<" if body[start + 1] & 1 else ">"
        sec, nanosec = struct.unpack_from(order + "iI", body, start + 4)
        return sec * 1_000_000_000 + nanosec

    def _learn(self, body: bytes, flags: int) -> None:
        # DATA: extraFlags(2) octetsToInlineQos(2) readerId(4) writerId(4) writerSN(8) [inline QoS] payload.
        order = "<" if flags & 1 else ">"
        (to_inline_qos,) = struct.unpack_from(order + "H", body, 2)
        start = 4 + to_inline_qos
        if flags & 0x02:   # Q: an inline QoS parameter list (no encapsulation header) precedes the payload
            while start + 4 <= len(body):
                pid, length = struct.unpack_from(order + "HH", body, start)
                start += 4 + length
                if pid == PID_SENTINEL:
                    break
        if not flags & 0x04:   # D: no serialized data (a dispose or unregister)
            return
        endpoint = sedp_endpoint(body[start:])
        if endpoint:
            self.names[endpoint[0]] = endpoint[1]

    def as_json(self) -> dict:
        table: dict[str, dict[str, dict[str, list[float]]]] = {}
        for (direction, name, second), value in self.bytes.items():
            entry = table.setdefault(direction, {}).setdefault(name, {"seconds": [], "bytes": [], "samples": []})
            entry["seconds"].append(second)
            entry["bytes"].append(round(value, 1))
            entry["samples"].append(self.samples.get((direction, name, second), 0))
        return {"directions": table, "named_endpoints": len(self.names), "unnamed": sorted(self.unnamed)[:50],
                "wire_times": {topic: [[stamp, round(t, 6)] for stamp, t in rows]
                               for topic, rows in self.wire_times.items()}}


class Reassembly:
    """IPv4 fragments to datagrams (a SEDP announcement of a node with many endpoints exceeds the 1500-byte MTU)."""

    def __init__(self) -> None:
        self.pending: dict[tuple, dict] = {}

    def add(self, packet: bytes) -> tuple[bytes, int] | None:
        """The IPv4 payload and its wire bytes once the datagram is whole, else None."""
        header_length = (packet[0] & 0x0F) * 4
        total = struct.unpack_from(">H", packet, 2)[0]
        ident, flags_offset = struct.unpack_from(">HH", packet, 4)
        more, offset = flags_offset & 0x2000, (flags_offset & 0x1FFF) * 8
        payload = packet[header_length:total]
        if not more and offset == 0:
            return payload, total
        key = (packet[12:16], packet[16:20], ident)
        entry = self.pending.setdefault(key, {"parts": {}, "wire": 0, "end": None, "born": time.monotonic()})
        entry["parts"][offset] = payload
        entry["wire"] += total
        if not more:
            entry["end"] = offset + len(payload)
        if entry["end"] is not None and sum(len(p) for p in entry["parts"].values()) >= entry["end"]:
            del self.pending[key]
            data = b"".join(entry["parts"][o] for o in sorted(entry["parts"]))
            return data, entry["wire"]
        if len(self.pending) > 256:   # fragments whose rest never came (the link was cut): forget the oldest
            oldest = min(self.pending, key=lambda k: self.pending[k]["born"])
            del self.pending[oldest]
        return None


SO_RCVBUFFORCE = 33             # <asm-generic/socket.h>
SOL_PACKET, PACKET_STATISTICS = 263, 6   # <linux/socket.h>, <linux/if_packet.h>
CAPTURE_BUFFER_BYTES = 32 * 1024 * 1024


def capture(interface: str, out: str, names: dict[str, str], stamped_topics: set[str], ready: str | None = None) -> int:
    stop = {"now": False}

    def on_signal(signum, frame) -> None:
        stop["now"] = True

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
    sock.bind((interface, 0))
    sock.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
    # A deep receive buffer (root may exceed rmem_max): the start-up bursts of discovery (hundreds of kB in a few
    # seconds) overflowed the default ~200 kB while a loaded machine left this process waiting, and an endpoint
    # whose announcement was dropped here is counted as "unnamed" for the whole run. Drops are counted below.
    sock.setsockopt(socket.SOL_SOCKET, SO_RCVBUFFORCE, CAPTURE_BUFFER_BYTES)
    sock.settimeout(0.2)
    if ready:   # the socket is bound: whoever started the capture may now start the participants
        Path(ready).write_text("capturing\n")
    accounting, fragments = RtpsAccounting(stamped_topics), Reassembly()
    packets = 0
    while not stop["now"]:
        try:
            frame, ancillary, _, _ = sock.recvmsg(65535, 64)
        except socket.timeout:
            continue
        except InterruptedError:
            continue
        except OSError as error:
            if error.errno in (errno.ENETDOWN, errno.ENXIO):   # the link is cut: wait for it to come back
                time.sleep(0.05)
                continue
            raise
        wire_time = time.time()
        for level, kind, data in ancillary:   # the kernel's time of the frame, not when this loop got to it
            if level == socket.SOL_SOCKET and kind == SO_TIMESTAMPNS and len(data) >= 16:
                seconds, nanoseconds = struct.unpack_from("qq", data)
                wire_time = seconds + 1e-9 * nanoseconds
        second = int(wire_time)
        packets += 1
        ethertype = struct.unpack_from(">H", frame, 12)[0]
        if ethertype != ETH_P_IP:
            accounting.bytes[("link layer", "ARP and other non-IPv4", second)] += len(frame) - 14
            continue
        packet = frame[14:]
        source, destination = socket.inet_ntoa(packet[12:16]), socket.inet_ntoa(packet[16:20])
        direction = f"{names.get(source, source)}->{names.get(destination, destination)}"
        whole = fragments.add(packet)
        if whole is None:
            continue
        datagram, wire = whole
        if packet[9] != socket.IPPROTO_UDP or len(datagram) < 8:
            accounting.bytes[(direction, "IPv4 other than UDP", second)] += wire
            continue
        accounting.datagram(direction, second, wire, datagram[8:], wire_time)
    result = accounting.as_json()
    result["interface"] = interface
    result["frames"] = packets
    # struct tpacket_stats {tp_packets, tp_drops} (since the last read): frames the kernel dropped for this socket.
    result["kernel_drops"] = struct.unpack("II", sock.getsockopt(SOL_PACKET, PACKET_STATISTICS, 8))[1]
    with open(out, "w") as handle:
        json.dump(result, handle)
    return 0


def summarise(capture_json: dict, start: float | None = None, end: float | None = None) -> dict:
    """Bytes/s and samples/s per direction and topic over [start, end) of wall time (whole capture if None)."""
    summary: dict[str, dict[str, dict[str, float]]] = {}
    for direction, topics in capture_json.get("directions", {}).items():
        for name, entry in topics.items():
            pairs = [(s, b, n) for s, b, n in zip(entry["seconds"], entry["bytes"], entry["samples"])
                     if (start is None or s >= start) and (end is None or s < end)]
            if not pairs:
                continue
            summary.setdefault(direction, {})[name] = {"bytes": sum(b for _, b, _ in pairs),
                                                       "samples": sum(n for _, _, n in pairs)}
    span = None if start is None or end is None else max(end - start, 1e-9)
    if span:
        for topics in summary.values():
            for entry in topics.values():
                entry["bytes_per_s"] = round(entry["bytes"] / span, 1)
                entry["samples_per_s"] = round(entry["samples"] / span, 2)
    return summary


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--interface", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--name", action="append", default=[], metavar="ADDRESS=NAME",
                        help="name an IPv4 address in the directions (e.g. <master's address>=master)")
    parser.add_argument("--stamps", nargs="*", default=[], metavar="TOPIC",
                        help="header-stamped ROS topics whose samples' stamps and wire times are kept")
    parser.add_argument("--ready", metavar="FILE", help="written once the capture socket is bound")
    args = parser.parse_args(argv)
    names = dict(item.split("=", 1) for item in args.name)
    try:
        return capture(args.interface, args.out, names, set(args.stamps), args.ready)
    except PermissionError:
        print("[traffic] refused: a packet capture needs root (CAP_NET_RAW)", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
