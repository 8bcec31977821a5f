"""The two-station analysis (fic_teleop_bringup/station_analysis.py) takes which stream belongs to which station from
the run profile's station layout: a profile that moves a node moves its stream's gap statistics to the other side."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fic_teleop_bringup import run_profile
from fic_teleop_bringup.station_analysis import GAP_STREAM_PUBLISHERS, link_cut_figures, station_streams
from fic_teleop_bringup.station_layout import StationLayout
from fic_teleop_bringup.workspace import PROFILES

BUILT_IN = run_profile.merged(run_profile.read_layer(PROFILES / "realtime.yaml"),
                              run_profile.read_layer(PROFILES / "two_stations.yaml"))


def _layout_with_the_planner_in(station: str) -> StationLayout:
    """The built-in layout with the planner moved to ``station`` (as a profile of one's own would move it)."""
    stations = {name: dict(BUILT_IN["stations"][name]) for name in run_profile.STATION_NAMES}
    for name in run_profile.STATION_NAMES:
        stations[name]["nodes"] = [node for node in stations[name]["nodes"] if node != "planner"]
    stations[station]["nodes"].append("planner")
    profile = run_profile.merged(BUILT_IN, {"stations": stations})
    run_profile.check_stations_whole(profile["stations"])
    return StationLayout.from_profile(profile)


def test_each_stream_is_on_its_publishers_station() -> None:
    streams = station_streams(StationLayout.from_profile(BUILT_IN))
    assert "/planner/desired_pose" in streams["robot"] and "/joint_states" in streams["robot"]
    assert "/master/teleop_command" in streams["master"] and "/master/feedback_wrench" in streams["master"]
    assert sorted(streams["robot"] + streams["master"]) == sorted(GAP_STREAM_PUBLISHERS)


def test_a_moved_node_takes_its_stream_to_the_other_station(tmp_path: Path) -> None:
    moved = _layout_with_the_planner_in("master")
    assert "/planner/desired_pose" in station_streams(moved)["master"]
    assert "/planner/desired_pose" not in station_streams(moved)["robot"]
    # the gap statistics read it from the master station's bag: 100 Hz with a 0.31 s gap (5.49 to 5.8 s) inside the cut
    # [5, 6] s
    planner = np.concatenate([np.arange(0.0, 5.5, 0.01), np.arange(5.8, 10.0, 0.01)])
    robot = {"logs": {"/joint_states": np.arange(0.0, 10.0, 0.002)}, "messages": {}}
    master = {"logs": {"/planner/desired_pose": planner}, "messages": {}}
    events = {"down_wall": 5.0, "up_wall": 6.0}
    figures = link_cut_figures(robot, master, events, tmp_path, moved)
    gaps = figures["master_station_streams"]["/planner/desired_pose"]
    assert gaps["messages"] == len(planner) and abs(gaps["longest_gap_in_cut_s"] - 0.31) < 1e-6
    assert "/planner/desired_pose" not in figures["robot_station_streams"]
    # and on the robot station (the built-in layout) the same bags show the robot's recorder without it
    kept = link_cut_figures(robot, master, events, tmp_path, _layout_with_the_planner_in("robot"))
    assert kept["robot_station_streams"]["/planner/desired_pose"] == {"messages": 0}
