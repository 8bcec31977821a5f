"""The launcher's --quiet-tail: after --duration the planner's circle stops and the operator's target holds still
(planner stop_time and device quiet_from at the same stamp), and the run folder records where the tail starts."""
from __future__ import annotations

from pathlib import Path

import pytest

from fic_core.planner_station import PlannerParameters, PlannerStation
from fic_teleop_bringup import teleop_launcher
from fic_teleop_bringup.launch_checks import ArgumentRefusal, check_options


def _graph(*argv: str) -> dict:
    args = teleop_launcher.parse_arguments(list(argv))
    teleop_launcher.resolve_defaults(args)
    return {node.name: node for spec in teleop_launcher.graph(args, Path("bag")) for node in (spec.members or [spec])}


def test_the_tail_starts_at_the_end_of_the_task_for_the_planner_and_the_operator_alike() -> None:
    nodes = _graph("--duration", "14", "--quiet-tail", "10")
    origin = nodes["haptic_device"].params["script_start_time"]
    assert nodes["haptic_device"].params["quiet_from"] == pytest.approx(origin + 14.0)
    assert nodes["planner"].params["stop_time"] == pytest.approx(origin + 14.0)


def test_without_a_tail_neither_side_is_told_to_stop() -> None:
    nodes = _graph("--duration", "14")
    assert "quiet_from" not in nodes["haptic_device"].params and "stop_time" not in nodes["planner"].params


def test_a_negative_tail_is_refused_in_one_line() -> None:
    args = teleop_launcher.parse_arguments(["--quiet-tail", "-1"])
    with pytest.raises(ArgumentRefusal, match="--quiet-tail"):
        check_options(args)


def test_the_planner_comes_to_rest_on_the_circles_point_at_its_stop_time() -> None:
    import yaml

    from fic_teleop_bringup.workspace import CONFIG

    values = yaml.safe_load((CONFIG / "planner.yaml").read_text())["/**"]["ros__parameters"]
    values = {**values, "start_time": 0.0, "start_position": []}
    stopping = PlannerStation(PlannerParameters.from_values({**values, "stop_time": 3.0}), 0.0)
    running = PlannerStation(PlannerParameters.from_values(values), 0.0)
    points = {}
    for step in range(0, 601):   # 6 s at 100 Hz
        now = step / 100.0
        points[now] = (stopping.update(now).position, running.update(now).position)
    assert points[2.5][0] == pytest.approx(points[2.5][1])             # the same circle before the stop
    assert abs(points[6.0][0] - points[5.0][0]).max() < 1e-5           # at rest (10 um) a few time constants after
    assert abs(points[6.0][1] - points[5.0][1]).max() > 1e-2           # the circle itself goes on
