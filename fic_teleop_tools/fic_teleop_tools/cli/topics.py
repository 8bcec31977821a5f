"""topic list / echo / hz, over rclpy's graph queries and subscriptions."""
from __future__ import annotations

import array
import math
import sys
import time
from collections import deque

import numpy as np
import rclpy
import yaml
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message

from fic_core.errors import FicInputError
from fic_teleop_runtime.message_types import message_class
from fic_teleop_tools.cli.errors import CommandError
from fic_teleop_tools.cli.graph import graph_node, settle, topic_type

# Best effort matches every publisher (a reliable reader would not match a best-effort writer); a deep queue so
# that a 1 kHz topic is not thinned by the reader while it is being printed.
ECHO_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT)


def message_to_plain(message) -> object:
    """A message as nested dicts and lists in field order (what `ros2 topic echo` prints as YAML)."""
    if hasattr(message, "get_fields_and_field_types"):
        return {name: message_to_plain(getattr(message, name)) for name in message.get_fields_and_field_types()}
    if isinstance(message, (np.ndarray, array.array)):
        return message.tolist()
    if isinstance(message, np.generic):
        return message.item()
    if isinstance(message, (list, tuple)):
        return [message_to_plain(item) for item in message]
    if isinstance(message, (bytes, bytearray)):
        return list(message)
    if isinstance(message, float) and not math.isfinite(message):
        return str(message)
    return message


def _subscribable(topic: str, timeout: float, node) -> type:
    type_name = topic_type(node, topic, timeout)
    try:
        return message_class(type_name)
    except FicInputError as error:
        raise CommandError(f"cannot subscribe to {topic}: its type {type_name} is not installed here ({error})") \
            from None


def topic_list(show_types: bool, timeout: float) -> int:
    with graph_node() as node:
        topics = settle(node, lambda: sorted(node.get_topic_names_and_types()), timeout)
    for name, types in topics:
        print(f"{name} [{', '.join(types)}]" if show_types else name)
    return 0


def topic_echo(topic: str, count: int | None, timeout: float, field: str | None) -> int:
    with graph_node() as node:
        message_type = _subscribable(topic, timeout, node)
        received: deque = deque()
        node.create_subscription(message_type, topic, lambda data: received.append(data), ECHO_QOS, raw=True)
        printed = 0
        while rclpy.ok() and (count is None or printed < count):
            rclpy.spin_once(node, timeout_sec=0.1)
            while received and (count is None or printed < count):
                plain = message_to_plain(deserialize_message(received.popleft(), message_type))
                for part in (field.split(".") if field else []):
                    if not isinstance(plain, dict) or part not in plain:
                        raise CommandError(f"{topic} has no field {field!r}")
                    plain = plain[part]
                text = yaml.safe_dump(plain, sort_keys=False, default_flow_style=False, width=120)
                sys.stdout.write(text if text.endswith("\n") else text + "\n")
                sys.stdout.write("---\n")
                sys.stdout.flush()
                printed += 1
    return 0


def topic_hz(topic: str, window: int, duration: float | None, timeout: float) -> int:
    """Receive rate from the receive times of the last `window` messages, printed every second."""
    with graph_node() as node:
        message_type = _subscribable(topic, timeout, node)
        arrivals: deque = deque(maxlen=window)
        node.create_subscription(message_type, topic, lambda _: arrivals.append(time.monotonic()), ECHO_QOS,
                                 raw=True)
        start = last_print = time.monotonic()
        total_before = 0
        while rclpy.ok():
            rclpy.spin_once(node, timeout_sec=0.05)
            now = time.monotonic()
            finished = duration is not None and now - start >= duration
            if now - last_print >= 1.0 or finished:
                last_print = now
                if len(arrivals) >= 2:
                    periods = np.diff(np.array(arrivals))
                    print(f"average rate: {1.0 / periods.mean():.3f}\n\tmin: {periods.min():.6f}s max: "
                          f"{periods.max():.6f}s std dev: {periods.std():.6f}s window: {len(arrivals)}", flush=True)
                elif total_before == len(arrivals):
                    print(f"no new messages on {topic}", flush=True)
                total_before = len(arrivals)
            if finished:
                break
        if duration is not None and len(arrivals) < 2:
            raise CommandError(f"fewer than 2 messages on {topic} in {duration:g} s")
    return 0
