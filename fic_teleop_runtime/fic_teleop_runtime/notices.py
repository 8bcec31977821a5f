"""Log lines of a node's inputs and of fic_core's notices, without flooding the log at 1 kHz.

fic_core returns what the caller should say as (level, text) notices; a refused input is said once per topic and
period. rclpy's own throttle is per call site, so one refused topic would silence another's line if they shared
one; ``RefusalLog`` throttles per topic instead.
"""
from __future__ import annotations

import time
from collections.abc import Iterable

from rclpy.impl.rcutils_logger import RcutilsLogger

THROTTLE_S = 2.0  # [s] one line per topic (or per repeated notice) at most this often


def log_notices(logger: RcutilsLogger, notices: Iterable[tuple[str, str]], throttle_s: float = THROTTLE_S) -> None:
    """fic_core's notices: ``info``, ``warning``, and ``error`` / ``repeated_warning`` (said at every tick while
    their cause lasts: at most once per ``throttle_s``). One call site per severity, as rclpy's logger requires."""
    for level, text in notices:
        if level == "info":
            logger.info(text)
        elif level == "warning":
            logger.warning(text)
        elif level == "repeated_warning":
            logger.warning(text, throttle_duration_sec=throttle_s)
        else:
            logger.error(text, throttle_duration_sec=throttle_s)


class RefusalLog:
    """One error line per refused topic and ``period`` (monotonic time)."""

    def __init__(self, logger: RcutilsLogger, period: float = THROTTLE_S) -> None:
        self._logger = logger
        self._period = period
        self._last: dict[str, float] = {}

    def refuse(self, topic: str, reason: object, consequence: str = "keeping the last good value") -> None:
        now = time.monotonic()
        last = self._last.get(topic)
        if last is None or now - last >= self._period:
            self._last[topic] = now
            self._logger.error(f"refusing {topic}: {reason}; {consequence}")
