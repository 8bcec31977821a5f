"""The one sequential reader of rosbag2-layout MCAP bags, finished or torn (the recorder was killed).

Built on the mcap library's StreamReader with chunk CRC validation only, so it reads any such bag (one written
by `ros2 bag record -s mcap` as well as ours) from the files' own schemas, and it does not share code with the
writer in bag_writer.py: a bag the writer got wrong is not read back by the writer's own assumptions.
At a torn tail (a record cut short, a chunk whose CRC or decompression fails) it stops cleanly instead of
raising and records why.
"""
from __future__ import annotations

import os
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

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
