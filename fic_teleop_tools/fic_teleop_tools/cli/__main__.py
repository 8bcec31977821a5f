"""scripts/fic <group> <verb> ...: see `scripts/fic --help` and docs/TOOLS.md."""
from __future__ import annotations

import argparse
import sys

from fic_teleop_tools.cli.errors import CommandError

GROUPS = """the ros2 command each one stands in for:
  topic list [-t]                       ros2 topic list [-t]
  topic echo TOPIC [--once|-n N]        ros2 topic echo TOPIC [--once]
  topic hz TOPIC [--duration S]         ros2 topic hz TOPIC
  param list NODE                       ros2 param list NODE
  param get NODE NAME                   ros2 param get NODE NAME
  param set NODE NAME VALUE             ros2 param set NODE NAME VALUE
  param dump NODE                       ros2 param dump NODE
  node list                             ros2 node list
  bag info BAG                          ros2 bag info BAG
  bag recover BAG NEW_BAG               (ros2 bag reindex rebuilds a torn bag's index; this rewrites it)
  bag play BAG [--rate R] [--topics T]  ros2 bag play BAG [--rate R] [--topics T]
and two of our own (docs/TOOLS.md, "Datasets"):
  dataset export RUN_DIR... --out DIR   runs as a LeRobot v3.0 dataset, one episode a run
  episode mark keep|discard|success|failure   mark the running episode (recorded on /episode/marker)
"""


def parser() -> argparse.ArgumentParser:
    top = argparse.ArgumentParser(prog="scripts/fic", description="Wheel-only stand-ins for ros2 topic, param, "
                                  "node and bag commands.", epilog=GROUPS,
                                  formatter_class=argparse.RawDescriptionHelpFormatter)
    groups = top.add_subparsers(dest="group", required=True)

    topic = groups.add_parser("topic").add_subparsers(dest="verb", required=True)
    listing = topic.add_parser("list", help="topics in the graph")
    listing.add_argument("-t", "--show-types", action="store_true")
    listing.add_argument("--timeout", type=float, default=3.0, help="longest discovery wait [s]")
    echo = topic.add_parser("echo", help="print a topic's messages as YAML")
    echo.add_argument("topic")
    echo.add_argument("field", nargs="?", default=None, help="only this field (dotted path), e.g. header.stamp")
    echo.add_argument("--once", action="store_true", help="one message, then exit")
    echo.add_argument("-n", "--count", type=int, default=None, help="this many messages, then exit")
    echo.add_argument("--timeout", type=float, default=5.0, help="how long to wait for the topic to appear [s]")
    hz = topic.add_parser("hz", help="a topic's receive rate")
    hz.add_argument("topic")
    hz.add_argument("--window", type=int, default=10000)
    hz.add_argument("--duration", type=float, default=None, help="stop after this many seconds")
    hz.add_argument("--timeout", type=float, default=5.0)

    param = groups.add_parser("param").add_subparsers(dest="verb", required=True)
    for verb in ("list", "get", "set", "dump"):
        command = param.add_parser(verb)
        command.add_argument("node")
        if verb in ("get", "set"):
            command.add_argument("name")
        if verb == "set":
            command.add_argument("value")
        command.add_argument("--timeout", type=float, default=5.0)

    node = groups.add_parser("node").add_subparsers(dest="verb", required=True)
    node_list = node.add_parser("list")
    node_list.add_argument("--timeout", type=float, default=3.0)

    bag = groups.add_parser("bag").add_subparsers(dest="verb", required=True)
    bag.add_parser("info").add_argument("bag")
    repair = bag.add_parser("recover", help="rewrite a torn bag (a killed recorder's) into a complete one")
    repair.add_argument("bag")
    repair.add_argument("new_bag")
    play = bag.add_parser("play", help="publish a bag's messages on their topics, paced as recorded")
    play.add_argument("bag")
    play.add_argument("-r", "--rate", type=float, default=1.0)
    play.add_argument("--topics", nargs="+", default=None)
    play.add_argument("--wait-for-subscribers", type=float, default=0.0, metavar="SECONDS",
                      help="first wait up to this long until every topic has a subscriber (e.g. a recorder)")

    dataset = groups.add_parser("dataset").add_subparsers(dest="verb", required=True)
    export = dataset.add_parser("export", help="runs as a LeRobot v3.0 dataset (one episode a run)")
    export.add_argument("runs", nargs="+", metavar="RUN_DIR", help="run folders (runs/<date-time>), or bag folders "
                        "with --scene")
    export.add_argument("--out", required=True, help="the dataset's folder (new or empty)")
    export.add_argument("--fps", type=int, default=None,
                        help="frames a second (default: the rate the camera's source was recorded at, one for all "
                             "runs; not above it)")
    export.add_argument("--task", default=None, help="every episode's task (default: each run's --task, else the "
                                                       "scene's)")
    export.add_argument("--scene", default=None, help="the simulated scene the camera renders (default: run.json's)")
    export.add_argument("--size", default="640x480", help="the camera's WIDTHxHEIGHT (default 640x480)")

    episode = groups.add_parser("episode").add_subparsers(dest="verb", required=True)
    mark = episode.add_parser("mark", help="mark the running episode: keep, discard, success or failure")
    mark.add_argument("event")
    mark.add_argument("--timeout", type=float, default=5.0, help="how long to wait for the recorder [s]")
    return top


def run(args: argparse.Namespace) -> int:
    if args.group == "topic":
        from fic_teleop_tools.cli import topics
        if args.verb == "list":
            return topics.topic_list(args.show_types, args.timeout)
        if args.verb == "echo":
            return topics.topic_echo(args.topic, 1 if args.once else args.count, args.timeout, args.field)
        return topics.topic_hz(args.topic, args.window, args.duration, args.timeout)
    if args.group == "param":
        from fic_teleop_tools.cli import params
        if args.verb == "list":
            print("\n".join(f"  {name}" for name in params.param_list(args.node, args.timeout)))
            return 0
        if args.verb == "get":
            return params.param_get(args.node, args.name, args.timeout)
        if args.verb == "set":
            return params.param_set(args.node, args.name, args.value, args.timeout)
        return params.param_dump(args.node, args.timeout)
    if args.group == "node":
        from fic_teleop_tools.cli.graph import graph_node, node_names, settle
        with graph_node() as graph:
            names = settle(graph, lambda: node_names(graph), args.timeout)
        print("\n".join(names))
        return 0
    if args.group in ("dataset", "episode"):
        from fic_teleop_tools.cli import datasets
        if args.group == "dataset":
            return datasets.dataset_export(args.runs, args.out, args.fps, args.task, args.scene, args.size)
        return datasets.episode_mark(args.event, args.timeout)
    from fic_teleop_tools.cli import bags
    if args.verb == "info":
        return bags.bag_info(args.bag)
    if args.verb == "recover":
        return bags.bag_recover(args.bag, args.new_bag)
    return bags.bag_play(args.bag, args.rate, args.topics, args.wait_for_subscribers)


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    try:
        return run(args)
    except CommandError as error:
        print(f"fic {args.group} {args.verb}: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # `scripts/fic topic echo ... | head`: the reader has what it wanted
        sys.stderr.close()
        return 0


if __name__ == "__main__":
    sys.exit(main())
