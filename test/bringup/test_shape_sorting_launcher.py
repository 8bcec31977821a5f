"""The launcher's shape-sorting operator option: the shape_sorting scene runs E2's closed-loop operator by default
(the script stays selectable), the operator gets the delayed video with every piece, and the option is refused
for another scene."""
from __future__ import annotations

from pathlib import Path

import pytest

from fic_teleop_bringup.launch_checks import ArgumentRefusal, check_options
from fic_teleop_bringup.teleop_launcher import VIDEO_ROUTES, graph, parse_arguments, resolve_defaults


def _graph(*argv: str) -> dict:
    args = parse_arguments(list(argv))
    resolve_defaults(args)
    check_options(args)
    return {spec.name: spec.params for spec in graph(args, Path("/tmp/unused/bag"))}


def test_the_shape_sorting_scene_runs_the_shape_sorting_operator_by_default() -> None:
    nodes = _graph("--scene", "shape_sorting", "--delay", "0.5")
    assert nodes["haptic_device"]["operator_source"] == "shape_sorting"
    assert nodes["haptic_device"]["assumed_one_way_delay"] == 0.5   # the latency it has learnt is the run's
    # The video crosses the backward link as the force feedback does; the robot publishes it at a camera's rate.
    assert set(VIDEO_ROUTES) <= set(nodes["channel_backward"]["routes"])
    # its deliveries are logged (the video's delay is read from them), and F_R's still are
    assert nodes["channel_backward"]["logged_deliveries"] == [
        "/master/feedback_wrench", "/master/video/tcp_pose", "/master/video/object_poses"]
    assert nodes["robot"]["object_pose_rate_hz"] > 0.0
    assert "routes" not in nodes["channel_forward"]


def test_the_script_stays_selectable_and_the_other_scenes_keep_theirs() -> None:
    scripted = _graph("--scene", "shape_sorting", "--operator", "scripted")
    assert scripted["haptic_device"]["operator_source"] == "scripted"
    assert "routes" not in scripted["channel_backward"] or not set(VIDEO_ROUTES) & set(
        scripted["channel_backward"]["routes"])
    assert _graph()["haptic_device"]["operator_source"] == "scripted"   # E1's default


@pytest.mark.parametrize("argv", [("--operator", "shape-sorting"),
                                  ("--operator", "shape-sorting", "--scene", "free_space")])
def test_the_operator_is_refused_for_another_scene(argv) -> None:
    with pytest.raises(ArgumentRefusal, match="--operator shape-sorting drives the shape_sorting scene only"):
        _graph(*argv)
