"""The recorder's topic table (config/recorder.yaml) names only topics of the graph: each is in docs/INTERFACES.md's
table of the graph, where its publisher is named. A table entry no node publishes records nothing and, in a
two-station run, makes the robot station's recorder subscribe to a topic only the link could match."""
from __future__ import annotations

import re

from conftest import REPO


def _graph_topics() -> set[str]:
    """The topics of INTERFACES.md's "The graph at a glance" table (its first column, in backticks)."""
    text = (REPO / "docs" / "INTERFACES.md").read_text()
    table = text[text.index("## The graph at a glance"):text.index("\n## ", text.index("## The graph at a glance") + 1)]
    rows = [line.split("|")[1] for line in table.splitlines() if line.startswith("| `")]
    return {topic for row in rows for topic in re.findall(r"`(/[^`]+)`", row)}


def test_every_recorded_topic_is_one_the_graph_publishes() -> None:
    from fic_teleop_tools.recording.recorder_node import default_topics

    graph = _graph_topics()
    assert "/replica/teleop_command" in graph and "/joint_states" in graph
    assert [topic for topic in default_topics() if topic not in graph] == []
