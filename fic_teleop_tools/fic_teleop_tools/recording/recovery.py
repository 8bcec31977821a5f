"""Torn-bag recovery: rewrite what a killed recorder left (no summary, no footer) into a complete bag folder."""
from __future__ import annotations

import os

import yaml

from fic_teleop_tools.recording.bag_reader import ReadResult, read_messages
from fic_teleop_tools.recording.bag_writer import BagSummary, BagWriter


def recover(src: str | os.PathLike, dst_bag_dir: str | os.PathLike) -> tuple[BagSummary, ReadResult]:
    """Rewrite a possibly torn bag into a complete bag folder at `dst_bag_dir` (every message up to the last
    complete chunk, with each topic's type, definition, type hash and offered QoS)."""
    result = ReadResult()
    writer = BagWriter(dst_bag_dir)
    channel_topics: dict[int, str] = {}
    for schema, channel, message in read_messages(src, result):
        if channel.id not in channel_topics:
            profiles = yaml.safe_load(channel.metadata.get("offered_qos_profiles", "")) or None
            writer.add_topic(channel.topic, schema.name, offered_qos_profiles=profiles,
                             definition=schema.data.decode(), type_hash=channel.metadata.get("topic_type_hash", ""))
            channel_topics[channel.id] = channel.topic
        writer.write(channel_topics[channel.id], message.data, message.log_time, message.publish_time)
    return writer.finish(), result
