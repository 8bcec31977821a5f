"""Who publishes and who reads each topic of a running graph: the bench's message budget per process.

    python -m fic_teleop_experiments.tools.graph_census --domain 17 --out census.json [--listen 3]

Joins the domain as a passive node (no publisher, no subscription of its own beyond rclpy's), waits ``--listen``
seconds for discovery, then writes {topic: {"publishers": [node, ...], "subscribers": [node, ...]}} for every topic
but rclpy's own (/rosout, /parameter_events). bench.py runs it once the main job's nodes are up and multiplies the
bag's message counts by it: what each process publishes and receives a second (``message_budget``).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

CENSUS_NODE = "fic_graph_census"
OWN_TOPICS = {"/rosout", "/parameter_events"}


def census(domain: int, listen_s: float) -> dict[str, dict[str, list[str]]]:
    """The endpoints of every topic on ``domain`` after ``listen_s`` seconds of discovery."""
    os.environ["ROS_DOMAIN_ID"] = str(domain)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    import rclpy

    rclpy.init()
    node = rclpy.create_node(CENSUS_NODE)
    try:
        deadline = time.monotonic() + listen_s
        while time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.1)
        table: dict[str, dict[str, list[str]]] = {}
        for topic, _ in node.get_topic_names_and_types():
            if topic in OWN_TOPICS:
                continue
            table[topic] = {
                "publishers": sorted(info.node_name for info in node.get_publishers_info_by_topic(topic)
                                     if info.node_name != CENSUS_NODE),
                "subscribers": sorted(info.node_name for info in node.get_subscriptions_info_by_topic(topic)
                                      if info.node_name != CENSUS_NODE)}
        return table
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def message_budget(endpoints: dict[str, dict[str, list[str]]], counts: dict[str, int], seconds: float,
                   processes: dict[str, list[str]]) -> tuple[dict[str, dict[str, float]], list[str]]:
    """Messages a second each process publishes and receives: a topic's bag count over ``seconds`` (the bag's wall
    span), once for each of the process's nodes that publishes it and once for each that reads it. ``processes``:
    process name -> its nodes (a group "a+b" holds a and b). Returns the table and the topics of the graph the bag
    does not hold (not counted: the recorder does not record them)."""
    table = {name: {"published_per_s": 0.0, "received_per_s": 0.0} for name in processes}
    unrecorded = sorted(topic for topic in endpoints if topic not in counts)
    if seconds <= 0.0:
        return table, unrecorded
    for topic, ends in endpoints.items():
        rate = counts.get(topic, 0) / seconds
        for name, nodes in processes.items():
            table[name]["published_per_s"] += rate * sum(node in nodes for node in ends["publishers"])
            table[name]["received_per_s"] += rate * sum(node in nodes for node in ends["subscribers"])
    for row in table.values():
        row["published_per_s"], row["received_per_s"] = round(row["published_per_s"], 1), round(row["received_per_s"],
                                                                                                1)
    return table, unrecorded


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--domain", type=int, required=True)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--listen", type=float, default=3.0, help="seconds of discovery before the census")
    args = parser.parse_args(argv)
    args.out.write_text(json.dumps(census(args.domain, args.listen), indent=2, sort_keys=True) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
