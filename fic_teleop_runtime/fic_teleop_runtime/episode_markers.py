"""Episode markers: what an operator says about the run while it goes (keep or discard it, success or failure).

A run is one episode of a demonstration dataset (docs/TOOLS.md, "Datasets"). Anyone may mark it, as often as they
like, by publishing one of ``EVENTS`` as a std_msgs/String on ``MARKER_TOPIC``: the keyboard operator's keys,
``scripts/fic episode mark EVENT``, or a node of one's own. The recorder records the topic like any other, and the
dataset export reads the bag's markers back through ``outcome``: the last keep/discard word decides whether the
episode is exported (kept unless discarded), the last success/failure word is its ``success`` (None: not marked).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

MARKER_TOPIC = "/episode/marker"
MARKER_TYPE = "std_msgs/msg/String"
KEEP, DISCARD, SUCCESS, FAILURE = "keep", "discard", "success", "failure"
EVENTS = (KEEP, DISCARD, SUCCESS, FAILURE)
# Its QoS is fic_teleop_runtime.qos.MARKERS (this module imports no ROS: the keyboard's key logic and the export's
# reading of a bag use it without a graph).


class MarkerError(ValueError):
    """A word that is not one of EVENTS."""


@dataclass(frozen=True)
class EpisodeOutcome:
    keep: bool = True
    success: bool | None = None
    marks: int = 0


def checked_event(word: str) -> str:
    """The marker word, lower-cased; MarkerError names the known ones."""
    event = word.strip().lower()
    if event not in EVENTS:
        raise MarkerError(f"unknown episode marker {word!r}: one of {', '.join(EVENTS)}")
    return event


def outcome(words: Iterable[str]) -> EpisodeOutcome:
    """The episode's outcome from its marks in the order they were made (the last of each pair wins). A word that
    is not a marker is refused, so that a typo in a node of one's own does not pass for "not marked"."""
    keep, success, marks = True, None, 0
    for word in words:
        event = checked_event(word)
        marks += 1
        if event in (KEEP, DISCARD):
            keep = event == KEEP
        else:
            success = event == SUCCESS
    return EpisodeOutcome(keep, success, marks)
