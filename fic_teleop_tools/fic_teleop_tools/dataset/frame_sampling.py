"""Frames at a fixed rate from streams sampled at their own rates: each frame as of its own time.

A frame at time t holds, of every stream, the newest sample stamped at or before t (a zero-order hold), never a
later one: a policy trained on the frames must not see a value that did not exist yet when the frame was taken.
Times are integer nanoseconds (header stamps), so "at or before" is exact; frame k of an episode starting at t0
is at t0 + round(k * 1e9 / fps) ns, and its LeRobot timestamp is k / fps.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


class SamplingError(ValueError):
    """Streams that cannot give every frame a sample (empty, unsorted, or no overlap)."""


def frame_times(start_ns: int, end_ns: int, fps: int) -> NDArray[np.int64]:
    """Frame times [ns] from ``start_ns`` every 1/fps up to and including ``end_ns``."""
    if fps <= 0:
        raise SamplingError(f"fps must be > 0, got {fps}")
    if end_ns < start_ns:
        raise SamplingError(f"the episode ends ({end_ns} ns) before it starts ({start_ns} ns)")
    count = (end_ns - start_ns) * fps // 1_000_000_000 + 1
    return start_ns + (np.arange(count, dtype=np.int64) * 1_000_000_000 + fps // 2) // fps


def held_indices(sample_ns: NDArray[np.int64], frames_ns: NDArray[np.int64], name: str = "stream") -> NDArray[np.intp]:
    """For each frame time, the index of the newest sample at or before it (zero-order hold)."""
    sample_ns = np.asarray(sample_ns, dtype=np.int64)
    if sample_ns.size == 0:
        raise SamplingError(f"{name}: no samples")
    if np.any(np.diff(sample_ns) < 0):
        raise SamplingError(f"{name}: stamps go back in time")
    indices = np.searchsorted(sample_ns, np.asarray(frames_ns, dtype=np.int64), side="right") - 1
    if indices.size and indices[0] < 0:
        raise SamplingError(f"{name}: a frame at {frames_ns[0]} ns comes before its first sample "
                            f"({sample_ns[0]} ns)")
    return indices


def common_span(streams: dict[str, NDArray[np.int64]]) -> tuple[int, int]:
    """The span every stream covers: from the latest first sample (before it some stream has no value yet) to the
    earliest last sample (after it some stream has stopped, and holding its last value would pass it off as new)."""
    empty = [name for name, stamps in streams.items() if len(stamps) == 0]
    if empty:
        raise SamplingError(f"no samples on {', '.join(empty)}")
    start = max(int(stamps[0]) for stamps in streams.values())
    end = min(int(stamps[-1]) for stamps in streams.values())
    if end < start:
        late = max(streams, key=lambda name: int(streams[name][0]))
        early = min(streams, key=lambda name: int(streams[name][-1]))
        raise SamplingError(f"{early} ends before {late} begins: the streams never overlap")
    return start, end


def stream_rate_hz(sample_ns: NDArray[np.int64]) -> float:
    """A stream's rate from the median interval of its stamps (robust to a few late or lost samples)."""
    intervals = np.diff(np.asarray(sample_ns, dtype=np.int64))
    intervals = intervals[intervals > 0]
    if intervals.size == 0:
        raise SamplingError("fewer than two distinct stamps: no rate")
    return 1e9 / float(np.median(intervals))
