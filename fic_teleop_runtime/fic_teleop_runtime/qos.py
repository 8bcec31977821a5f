"""The QoS profiles of the graph's topics, in one place so a writer and its readers cannot drift apart
(docs/INTERFACES.md lists which topic uses which).

Why each is what it is:
- ``STREAM``: a reader of device streams, set-points on their way through the channel, status topics: RELIABLE,
  KEEP_LAST 20. The channel is where loss is injected on purpose; DDS itself should add none.
- ``STREAM_WRITER``: every writer of those streams: RELIABLE, KEEP_LAST 1000 (a second at 1 kHz). A reliable
  KEEP_LAST writer overwrites the samples a stalled reader has not acknowledged yet, and those are lost for that
  reader for good: with 20, a recorder starved of CPU for a fraction of a second on a loaded machine lost 18
  /haptic/pose samples of a lockstep run; a reader stopped for 0.6 s at 1 kHz lost 0, 1 and 4 of 3000 (depth 20)
  and 0 in 3 tries (depth 1000). A deep writer history costs memory only; the readers keep their own depths.
  The channel's readers are ``STREAM`` on purpose: after a link cut the writer resends its whole history, and
  a channel reading it 1000 deep relayed seconds-old set-points, which the replica then refused as stale
  (a two-station cut run, 2026-12-04); at 20 it relays the newest 20 of them. A reader drops the oldest sample
  its node has not taken once its history is full, so a channel stalled past 20 samples (200 ms at the
  graph's 100 Hz) relays only the newest 20 of what came meanwhile.
- ``EVENTS``: button presses. A lost toggle would invert the teleoperation mode for the rest of the run.
- ``ROBOT_STREAM``: 1 kHz robot streams (joint states, the F/T wrench, /clock, the replica's torque command),
  writers and the lockstep reader of torque commands: a recorder must lose none (as ``STREAM_WRITER``), and in
  lockstep every answer counts, in order.
- ``NEWEST``: a reader for which only the newest sample matters (the replica's joint states, the F/T reading). A
  deep reader queue on a busy machine handed the control law a backlog of old states (measured: the arm was thrown
  about under overload); BEST_EFFORT because a reliable reader delivers in order, and one sample lost between
  processes held every later state back until the writer's heartbeat repaired it (50-90 ms without joint states).
- ``SET_POINT``: x_d' through the channel and x_d'' from the planner at the replica: no loss but the channel's,
  depth 1. A deeper queue behind a busy replica handed it commands up to depth x period old (measured: a pipeline
  latency p99 of about 200 ms with depth 20 at 100 Hz).
- ``MARKERS``: episode markers (episode_markers.py): RELIABLE and TRANSIENT_LOCAL, KEEP_LAST 50, so that a mark is
  not lost and a reader that joins late (a recorder looks for new topics every 0.5 s) still gets the marks made.
- ``RECORD_BATCH``: a fast stream's samples on their way to the recorder, many to a message (record_batch.py):
  RELIABLE, KEEP_LAST 50 (seconds of samples at a batch every 50 ms), so that a busy recorder loses none.
- ``DIAGNOSTICS``: /diagnostics, also rclcpp::SystemDefaultsQoS() as the RMW resolves it (``SYSTEM_DEFAULTS``,
  what the real drivers use: reliable, volatile, keep last 10).
"""
from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy


def reliable(depth: int) -> QoSProfile:
    """RELIABLE, volatile, KEEP_LAST ``depth``."""
    return QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=depth)


def best_effort(depth: int) -> QoSProfile:
    """BEST_EFFORT, volatile, KEEP_LAST ``depth``."""
    return QoSProfile(reliability=ReliabilityPolicy.BEST_EFFORT, history=HistoryPolicy.KEEP_LAST, depth=depth)


def latched(depth: int) -> QoSProfile:
    """RELIABLE, TRANSIENT_LOCAL, KEEP_LAST ``depth``: a late reader gets the last ``depth`` samples."""
    return QoSProfile(reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                      history=HistoryPolicy.KEEP_LAST, depth=depth)


WRITER_HISTORY = 1000  # samples a stream's writer keeps for a stalled reader: a second at 1 kHz
STREAM = reliable(20)
STREAM_WRITER = reliable(WRITER_HISTORY)
EVENTS = reliable(50)
ROBOT_STREAM = reliable(WRITER_HISTORY)
NEWEST = best_effort(1)
SET_POINT = reliable(1)
MARKERS = latched(50)
RECORD_BATCH = reliable(50)
DIAGNOSTICS = reliable(10)
SYSTEM_DEFAULTS = reliable(10)
