"""`--group`: nodes that share one process (fic_teleop_runtime.node_group) are still the graph's nodes: each keeps
its name, parameters and topics, the run keeps its figures, and every member stops clean."""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import REPO, assert_stopped_clean, isolated_env, reserved_domain, unclean_exit

from fic_teleop_bringup import node_groups, run_profile
from fic_teleop_bringup.launch_checks import ArgumentRefusal
from fic_teleop_bringup.station_layout import StationLayout
from fic_teleop_bringup.teleop_launcher import NodeSpec, node_command

LAUNCHER = REPO / "scripts" / "teleop_launcher.py"
GROUPS = ("channel_forward,channel_backward", "haptic_device,master")


def _specs() -> list[NodeSpec]:
    return [NodeSpec("sim_bridge", "robot_node", "robot", "robot.yaml"),
            NodeSpec("fic_teleop_tools", "recorder_node", "recorder"),
            NodeSpec("sim_bridge", "channel_node", "channel_forward", "channel.yaml", {"seed": 1}, niceness=-10),
            NodeSpec("sim_bridge", "channel_node", "channel_backward", "channel.yaml", {"seed": 2}),
            NodeSpec("fic_teleop_master", "master_node", "master", "master.yaml")]


def test_a_group_folds_its_members_into_one_process_at_the_first_members_place(tmp_path: Path) -> None:
    specs = node_groups.grouped(_specs(), node_groups.parse_groups(["channel_forward, channel_backward"]))
    assert [spec.name for spec in specs] == ["robot", "recorder", "channel_forward+channel_backward", "master"]
    group = specs[2]
    assert [member.name for member in group.members] == ["channel_forward", "channel_backward"]
    assert group.niceness == -10   # the most favoured member's
    written = {}

    def write(name: str, params: dict) -> Path:
        written[name] = params
        return tmp_path / f"{name}.yaml"

    command = node_groups.group_command(group, node_command, write)
    assert command[:3] == [sys.executable, "-m", "fic_teleop_runtime.node_group"]
    assert written == {"channel_forward": {"seed": 1}, "channel_backward": {"seed": 2}}   # each its own values
    nodes = [i for i, item in enumerate(command) if item == "--node"]
    assert [command[i + 1] for i in nodes] == ["sim_bridge/channel_node"] * 2
    second = command[nodes[1]:]
    assert "__node:=channel_backward" in second and str(tmp_path / "channel_backward.yaml") in second
    assert "__node:=channel_forward" not in second


@pytest.mark.parametrize("values, words", [
    (["master"], "--group needs at least two node names"),
    (["master,replica", "replica,planner"], "node 'replica' is named twice"),
])
def test_bad_group_values_are_refused(values, words) -> None:
    with pytest.raises(ArgumentRefusal, match=words):
        node_groups.parse_groups(values)


@pytest.mark.parametrize("group, words", [
    ("master,recorder", "recorder cannot share a process"),
    ("master,nosuch", "no node 'nosuch' in this graph"),
])
def test_ungroupable_or_unknown_nodes_are_refused(group, words) -> None:
    with pytest.raises(ArgumentRefusal, match=words):
        node_groups.grouped(_specs(), node_groups.parse_groups([group]))


def _graph() -> list[NodeSpec]:
    return [*_specs(), NodeSpec("sim_bridge", "haptic_device_node", "haptic_device", "haptic_device.yaml"),
            NodeSpec("sim_bridge", "keyboard_operator", "keyboard_operator", foreground=True)]


def _args(**given) -> argparse.Namespace:
    args = argparse.Namespace(**{"scheduling": "nice", "two_stations": False, "isolated": False, "time_mode": None,
                                 "profile": None, **given})
    args.run_profile = run_profile.resolve(args)   # the groups are the profile's
    return args


def test_the_default_groups_are_the_channel_pair_and_the_operators_side_present_in_the_graph() -> None:
    assert node_groups.run_groups([], _args(), _graph()) == [["channel_forward", "channel_backward"],
                                                            ["haptic_device", "master"]]   # no fd_adapter here
    assert node_groups.run_groups([["master", "robot"]], _args(), _graph()) == [["master", "robot"]]   # --group wins
    # a group left with one member is no group
    assert node_groups.run_groups([], _args(), [s for s in _graph() if s.name != "master"]) == [
        ["channel_forward", "channel_backward"]]


def _robot_and_replica(*groups: str) -> list[NodeSpec]:
    graph = [*_graph(), NodeSpec("fic_teleop_replica", "replica_node", "replica", "replica.yaml")]
    return node_groups.grouped(graph, node_groups.parse_groups(list(groups)))


def test_the_robot_and_the_replica_grouped_in_realtime_are_linked_in_process() -> None:
    specs = _robot_and_replica("robot,replica", "channel_forward,channel_backward")
    assert not node_groups.linked_in_process(specs)
    assert node_groups.link_in_process(specs, realtime=True, simulated_robot=True)
    assert node_groups.linked_in_process(specs)   # what the two-station link cut reads back
    members = {member.name: member for member in specs[0].members}
    assert members["robot"].params == {"controller_in_process": True}
    assert members["replica"].params == {"robot_in_process": True}
    assert node_groups.run_groups([], _args(), [*_graph(), members["replica"]])[0] == ["robot", "replica"]


@pytest.mark.parametrize("groups, realtime, simulated_robot", [
    (("robot,replica",), False, True),                 # lockstep: the replica answers each state over DDS
    (("robot,replica",), True, False),                 # a driver twin speaks DDS as the real driver would
    (("robot,master", "replica,planner"), True, True),  # not in one process
])
def test_the_robot_and_the_replica_are_not_linked_otherwise(groups, realtime, simulated_robot) -> None:
    graph = [*_graph(), NodeSpec("fic_teleop_planner", "planner_node", "planner", "planner.yaml"),
             NodeSpec("fic_teleop_replica", "replica_node", "replica", "replica.yaml")]
    specs = node_groups.grouped(graph, node_groups.parse_groups(list(groups)))
    assert not node_groups.link_in_process(specs, realtime=realtime, simulated_robot=simulated_robot)
    assert not node_groups.linked_in_process(specs)
    members = [member for spec in specs for member in (spec.members or [spec])]
    assert not any("controller_in_process" in m.params or "robot_in_process" in m.params for m in members)


def test_the_device_and_the_master_grouped_in_realtime_are_linked_in_process() -> None:
    specs = node_groups.grouped(_graph(), node_groups.parse_groups(["haptic_device,master"]))
    assert node_groups.link_handle_in_process(specs, realtime=True, simulated_device=True)
    members = {member.name: member for spec in specs for member in (spec.members or [])}
    assert members["haptic_device"].params == {"master_in_process": True}
    assert members["master"].params == {"device_in_process": True}


@pytest.mark.parametrize("groups, realtime, simulated_device", [
    (("haptic_device,master",), False, True),    # lockstep: the robot's step barrier waits for their stamps on DDS
    (("haptic_device,master",), True, False),    # the forcedimension_ros2 twin speaks DDS as the real driver would
    (("haptic_device,planner",), True, True),    # not in one process
])
def test_the_device_and_the_master_are_not_linked_otherwise(groups, realtime, simulated_device) -> None:
    graph = [*_graph(), NodeSpec("fic_teleop_planner", "planner_node", "planner", "planner.yaml")]
    specs = node_groups.grouped(graph, node_groups.parse_groups(list(groups)))
    assert not node_groups.link_handle_in_process(specs, realtime=realtime, simulated_device=simulated_device)
    members = [member for spec in specs for member in (spec.members or [spec])]
    assert not any("master_in_process" in m.params or "device_in_process" in m.params for m in members)


@pytest.mark.parametrize("given", [{"time_mode": "lockstep"}, {"hardware_twin": True}])
def test_lockstep_and_the_driver_twins_keep_the_robot_and_the_replica_apart(given) -> None:
    replica = NodeSpec("fic_teleop_replica", "replica_node", "replica", "replica.yaml")
    groups = node_groups.run_groups([], _args(**given), [*_graph(), replica])
    assert groups == [["channel_forward", "channel_backward"], ["haptic_device", "master"]]


@pytest.mark.parametrize("given", [{"isolated": True}, {"scheduling": "fifo"}])
def test_isolated_and_fifo_runs_have_no_default_groups(given) -> None:
    assert node_groups.run_groups([], _args(**given), _graph()) == []


def test_two_stations_group_within_each_station() -> None:
    """The channel pair is split across the stations; each half shares a process in its own: channel_backward with
    the operator's side in the master station, channel_forward with the planner in the robot station."""
    planner = NodeSpec("fic_teleop_planner", "planner_node", "planner", "planner.yaml")
    groups = node_groups.run_groups([], _args(two_stations=True), [*_graph(), planner])
    assert groups == [["haptic_device", "master", "channel_backward"], ["planner", "channel_forward"]]
    layout = StationLayout.from_profile(_args(two_stations=True).run_profile)
    assert [layout.station_of("+".join(group)) for group in groups] == ["master", "robot"]
    replica = NodeSpec("fic_teleop_replica", "replica_node", "replica", "replica.yaml")
    groups = node_groups.run_groups([], _args(two_stations=True), [*_graph(), planner, replica])
    assert groups[-1] == ["robot", "replica"] and layout.station_of("robot+replica") == "robot"   # linked there


def test_isolated_with_a_group_is_refused() -> None:
    with pytest.raises(ArgumentRefusal, match="--isolated"):
        node_groups.check_groups([["master", "planner"]], _args(isolated=True))


def test_a_groups_log_is_split_into_its_members_own_logs(tmp_path: Path) -> None:
    group = node_groups.grouped(_specs(), node_groups.parse_groups(["channel_forward,channel_backward"]))[2]
    node_groups.link_member_logs(tmp_path, group)
    (tmp_path / "channel_forward+channel_backward.log").write_text(
        "[INFO] [1764892800.123] [channel_forward]: channel up\n"
        "[WARN] [1764892800.200] [station.channel_backward.routes]: a route refused\n"
        "Traceback (most recent call last):\n  boom\n")
    assert (tmp_path / "channel_forward.log").read_text().startswith("[INFO]")   # the link, while it runs
    node_groups.split_log(tmp_path, group)
    forward = (tmp_path / "channel_forward.log").read_text()
    backward = (tmp_path / "channel_backward.log").read_text()
    assert not (tmp_path / "channel_forward.log").is_symlink()
    assert forward == ("[INFO] [1764892800.123] [channel_forward]: channel up\n"
                       "Traceback (most recent call last):\n  boom\n")
    assert backward.startswith("[WARN]") and "channel up" not in backward and "boom" in backward   # unclaimed: both
    assert (tmp_path / "channel_forward+channel_backward.log").read_text().count("\n") == 4   # kept whole


def test_group_with_fifo_scheduling_is_refused() -> None:
    args = argparse.Namespace(scheduling="fifo", two_stations=False)
    with pytest.raises(ArgumentRefusal, match="--scheduling fifo"):
        node_groups.check_groups([["master", "planner"]], args)


def test_the_node_group_refuses_an_unknown_executable_in_one_line() -> None:
    result = subprocess.run([sys.executable, "-m", "fic_teleop_runtime.node_group", "--node", "sim_bridge/nothing"],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert result.stderr.splitlines()[0] == "node_group: no executable 'nothing' in package 'sim_bridge'"


@pytest.mark.nodes
def test_a_default_lockstep_run_is_grouped_and_keeps_its_nodes_logs_and_figures(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with reserved_domain() as domain:
        process = subprocess.run([sys.executable, str(LAUNCHER), "--out", str(out), "--duration", "5",
                                  "--time-mode", "lockstep", "--no-video", "--wall-limit", "400"],
                                 env=isolated_env(tmp_path / "ros_log", domain), capture_output=True, text=True,
                                 timeout=600)
    assert_stopped_clean(process.returncode, process.stdout + process.stderr, "the launcher")
    record = json.loads((out / "run.json").read_text())
    assert record["node_groups"] == [g.split(",") for g in GROUPS]
    assert record["robot_replica_in_process"] is False   # lockstep: the replica answers each state over DDS
    logs = {log.name: log.read_text(errors="replace") for log in (out / "logs").glob("*.log")}
    assert {"channel_forward+channel_backward.log", "haptic_device+master.log"} <= set(logs)
    # each member's own log, with its own lines and not its partner's
    assert "[master]" in logs["master.log"] and "[haptic_device]" not in logs["master.log"]
    assert "[channel_backward]: channel up" in logs["channel_backward.log"]
    assert "[channel_forward]" not in logs["channel_backward.log"]
    for name, text in logs.items():
        assert not unclean_exit(0, text), f"{name}: {unclean_exit(0, text)}"
    shared = logs["channel_forward+channel_backward.log"]
    for node in ("channel_forward", "channel_backward"):   # each its own node, routes and stop line
        assert f"[{node}]: channel up" in shared and f"[{node}]: channel stopped" in shared
    assert "[master]" in logs["haptic_device+master.log"] and "[haptic_device]" in logs["haptic_device+master.log"]
    metrics = json.loads((out / "report" / "metrics.json").read_text())
    assert metrics["delay_one_way_ms"] == pytest.approx(200.0, abs=5.0)
    assert metrics["limit_violations"] == 0 and metrics["dropped_joint_states"] == 0
    # A grouped 6 s lockstep run (2026-12-02 16:00): 34 mm; the FIC saturates beyond x_b = 50 mm.
    assert metrics["free_motion_error_max_m"] < 0.05
