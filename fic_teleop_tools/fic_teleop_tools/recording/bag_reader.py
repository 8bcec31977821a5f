"""The one sequential reader of rosbag2-layout MCAP bags, finished or torn (the recorder was killed).

Built on the mcap library's StreamReader with chunk CRC validation only, so it reads any such bag (one written
by `ros2 bag record -s mcap` as well as ours) from the files' own schemas, and it does not share code with the
writer in bag_writer.py: a bag the writer got wrong is not read back by the writer's own assumptions.
At a torn tail (a record cut short, a chunk whose CRC or decompression fails) it stops cleanly instead of
raising and records why.

`read_indexed` is its fast path for a finished bag: every topic's receive times from the summary's chunk indexes
and the Message Index records (the MCAP specification's, which the writer puts after each chunk), and only the asked
topics' messages from their chunks; None where that cannot be done (no summary, a missing or inconsistent index), and
the caller reads sequentially. The launcher's verdicts and the two-station analysis read this way, in about a tenth of
the CPU of the sequential pass (docs/RESULTS.md).
"""
from __future__ import annotations

import os
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import numpy as np
from mcap.exceptions import EndOfFile, McapError
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import CRCValidationError, StreamReader


class BagReadError(RuntimeError):
    """The path is not a readable MCAP bag (no such file, no or several .mcap files in the folder)."""


def mcap_file(bag: str | os.PathLike) -> Path:
    """The .mcap file of a bag folder (rosbag2 layout) or the path itself if it is a file."""
    path = Path(bag)
    if path.is_dir():
        files = sorted(path.glob("*.mcap"))
        if len(files) != 1:
            raise BagReadError(f"{path}: expected one .mcap file in the bag folder, found {len(files)}"
                               + ("; split bags are not supported" if files else ""))
        return files[0]
    if not path.is_file():
        raise BagReadError(f"{path}: no such bag folder or .mcap file")
    return path


@dataclass
class ReadResult:
    """Outcome of a sequential read: whether the file ended with a valid footer, why reading stopped, and the
    schemas and channels seen (also those of topics that carried no message)."""
    complete: bool = False
    stopped_by: str = ""
    message_count: int = 0
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)


def read_messages(bag: str | os.PathLike, result: ReadResult | None = None
                  ) -> Iterator[tuple[Schema | None, Channel, Message]]:
    """Yield (schema, channel, message) in file order from a finished or a torn bag.

    A chunk is decoded whole before any of its messages is yielded, so a torn chunk yields nothing; `result`
    says whether the footer was reached and, if not, what stopped the read.
    """
    result = result if result is not None else ReadResult()
    schemas, channels = result.schemas, result.channels
    with open(mcap_file(bag), "rb") as stream:
        records = StreamReader(stream, validate_crcs=True).records
        while True:
            try:
                record = next(records)
            except StopIteration:
                result.complete = True
                return
            except (EndOfFile, McapError, CRCValidationError, struct.error, ValueError, EOFError) as error:
                result.stopped_by = f"{type(error).__name__}: {error}".strip(": ")
                return
            except Exception as error:  # zstd/lz4 errors on a torn compressed chunk have library-specific types
                result.stopped_by = f"{type(error).__name__}: {error}"
                return
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
            elif isinstance(record, Message):
                channel = channels[record.channel_id]
                result.message_count += 1
                yield schemas.get(channel.schema_id), channel, record


@dataclass
class IndexedRead:
    """What `read_indexed` gives: ``receive_times`` topic -> the recorder's receive (log) times [ns] of every message
    in file order; ``payloads`` topic -> (log time, serialized message) in file order, for the topics asked only;
    the schemas and channels of the summary."""
    receive_times: dict[str, np.ndarray] = field(default_factory=dict)
    payloads: dict[str, list[tuple[int, bytes]]] = field(default_factory=dict)
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)

    def decoded(self, topic: str, factory) -> list[tuple[int, object]] | None:
        """``topic``'s payloads decoded by ``factory`` (an mcap DecoderFactory, mcap_ros2's for ROS 2 bags), each with
        its log time [ns]; None if the topic was not asked for or its channel has no schema."""
        channel = next((c for c in self.channels.values() if c.topic == topic), None)
        schema = self.schemas.get(channel.schema_id) if channel is not None else None
        if topic not in self.payloads or schema is None:
            return None
        decoder = factory.decoder_for(channel.message_encoding, schema)
        return [(log_time, decoder(data)) for log_time, data in self.payloads[topic]]


MESSAGE_INDEX_OPCODE, MESSAGE_OPCODE = 0x07, 0x05
RECORD_PREFIX = 9          # opcode u8 + record length u64
MESSAGE_FIXED = 22         # channel id u16, sequence u32, log time u64, publish time u64


def _message_index(region: bytes) -> dict[int, np.ndarray]:
    """The Message Index records after one chunk: channel id -> (log time, offset in the chunk's records) rows."""
    rows, at = {}, 0
    while at + RECORD_PREFIX <= len(region):
        opcode, length = region[at], struct.unpack_from("<Q", region, at + 1)[0]
        body = at + RECORD_PREFIX
        if opcode == MESSAGE_INDEX_OPCODE:
            channel_id, size = struct.unpack_from("<HI", region, body)
            rows[channel_id] = np.frombuffer(region, dtype="<u8", count=size // 8, offset=body + 6).reshape(-1, 2)
        at = body + length
    return rows


def _chunk_records(stream, chunk_index) -> bytes:
    """A chunk's records, decompressed and checked against the chunk's CRC (as the sequential reader checks it)."""
    import zlib

    stream.seek(chunk_index.chunk_start_offset)
    record = stream.read(chunk_index.chunk_length)
    _, _, uncompressed_size, crc, name_length = struct.unpack_from("<QQQII", record, RECORD_PREFIX)
    start = RECORD_PREFIX + 32 + name_length   # start, end, size, CRC, the name's length, the name
    (records_length,) = struct.unpack_from("<Q", record, start)
    data = record[start + 8:start + 8 + records_length]
    if chunk_index.compression == "zstd":
        import zstandard
        data = zstandard.decompress(data, uncompressed_size)
    elif chunk_index.compression == "lz4":
        import lz4.frame
        data = lz4.frame.decompress(data)
    elif chunk_index.compression:
        raise McapError(f"chunk compression {chunk_index.compression!r} is not zstd, lz4 or none")
    if crc and zlib.crc32(data) != crc:
        raise CRCValidationError(expected=crc, actual=zlib.crc32(data), record=None)
    return data


def read_indexed(bag: str | os.PathLike, payload_topics: set[str]) -> IndexedRead | None:
    """Every topic's receive times from the finished bag's indexes (its summary's chunk indexes and the Message Index
    records after each chunk) without parsing one message record, and the serialized messages of ``payload_topics``
    from the chunks that hold them. The same times and messages, in the same order, as `read_messages`, for a
    fraction of its CPU: a 30 s run's bag of some 75,000 messages is read in about a tenth of the time.

    None when the bag cannot be read so (a torn bag has no summary; a writer may leave out the indexes, or an index
    may not match its chunk): `read_messages` then reads it whole."""
    from mcap.reader import SeekingReader

    try:
        with open(mcap_file(bag), "rb") as stream:
            summary = SeekingReader(stream, validate_crcs=True).get_summary()
            if summary is None:
                return None
            read = IndexedRead(schemas=dict(summary.schemas), channels=dict(summary.channels))
            topics = [channel.topic for channel in read.channels.values()]
            if len(topics) != len(set(topics)):   # a topic on two channels: its order is the file's, not per channel
                return None
            wanted = {channel_id for channel_id, channel in summary.channels.items()
                      if channel.topic in payload_topics}
            times: dict[int, list[np.ndarray]] = {}
            payloads: dict[int, list[tuple[int, bytes]]] = {}
            counted = 0
            for chunk_index in sorted(summary.chunk_indexes, key=lambda index: index.chunk_start_offset):
                if chunk_index.message_index_length == 0 and chunk_index.message_index_offsets:
                    return None
                if not chunk_index.message_index_offsets:
                    continue
                stream.seek(min(chunk_index.message_index_offsets.values()))
                rows = _message_index(stream.read(chunk_index.message_index_length))
                records = _chunk_records(stream, chunk_index) if wanted & rows.keys() else b""
                for channel_id, entries in rows.items():
                    entries = entries[np.argsort(entries[:, 1], kind="stable")]   # file order within the chunk
                    times.setdefault(channel_id, []).append(entries[:, 0])
                    counted += len(entries)
                    if channel_id in wanted:
                        for log_time, offset in entries.tolist():
                            opcode, length = records[offset], struct.unpack_from("<Q", records, offset + 1)[0]
                            record_channel = struct.unpack_from("<H", records, offset + RECORD_PREFIX)[0]
                            if opcode != MESSAGE_OPCODE or record_channel != channel_id:
                                return None
                            data = records[offset + RECORD_PREFIX + MESSAGE_FIXED:offset + RECORD_PREFIX + length]
                            payloads.setdefault(channel_id, []).append((log_time, data))
            if summary.statistics is not None and counted != summary.statistics.message_count:
                return None
    except Exception:   # a short file, a bad record or CRC, zstd/lz4's own errors: the sequential reader decides
        return None
    for channel_id, parts in times.items():
        topic = read.channels[channel_id].topic
        read.receive_times[topic] = np.concatenate(parts).astype(np.int64)   # one channel a topic (above)
    for channel_id, rows in payloads.items():
        read.payloads.setdefault(read.channels[channel_id].topic, []).extend(rows)
    return read
