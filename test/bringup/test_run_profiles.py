"""The launcher's run profiles (fic_teleop_bringup/profiles, run_profile.py): each mode's differences come from YAML."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml

from fic_teleop_bringup import run_profile, teleop_launcher
from fic_teleop_bringup.launch_supervision import EXIT_REFUSED
from fic_teleop_bringup.launch_timing import TimingBounds, timing_verdict
from fic_teleop_bringup.workspace import PROFILES

BUILT_IN = ("realtime", "lockstep", "paper_law", "hardware_twin", "two_stations")


def _run(*argv: str) -> tuple:
    args = teleop_launcher.parse_arguments(list(argv))
    teleop_launcher.resolve_defaults(args)
    return args, {spec.name: spec for spec in teleop_launcher.graph(args, Path("bag"))}


def test_the_built_in_profiles_are_there_and_every_key_of_theirs_is_known() -> None:
    assert set(BUILT_IN) <= set(run_profile.builtin_names())
    for name in run_profile.builtin_names():
        layer = run_profile.read_layer(PROFILES / f"{name}.yaml")   # raises on an unknown key or node
        assert layer["description"] and layer["options"], name
    # the base gives every key but a mode's own section, so that each layer need only name what it changes
    assert set(run_profile.read_layer(PROFILES / "realtime.yaml")) == set(run_profile.KEYS) - set(run_profile.MODE_KEYS)
    for key, name in run_profile.MODE_KEYS.items():
        assert key in run_profile.read_layer(PROFILES / f"{name}.yaml")


@pytest.mark.parametrize("name, option, value", [("lockstep", "time_mode", "lockstep"),
                                                 ("paper_law", "paper_law", True),
                                                 ("hardware_twin", "hardware_twin", True),
                                                 ("two_stations", "two_stations", True)])
def test_a_built_in_profile_by_name_is_its_option(name, option, value) -> None:
    by_profile, _ = _run("--profile", name)
    by_flag, _ = _run(*({"time_mode": ["--time-mode", "lockstep"]}.get(option, [f"--{option.replace('_', '-')}"])))
    assert getattr(by_profile, option) == value
    assert by_profile.run_profile == by_flag.run_profile
    assert by_profile.run_profile["layers"] == ["realtime", *(["lockstep"] if name == "lockstep" else []),
                                                *([name] if name != "lockstep" else [])]


def test_the_realtime_replica_rate_is_the_profiles_500_hz_and_follows_the_yaml(tmp_path, monkeypatch) -> None:
    assert yaml.safe_load((PROFILES / "realtime.yaml").read_text())["control_rate_hz"] == 500.0
    _, nodes = _run()
    assert nodes["replica"].params["control_rate"] == 500.0
    _, nodes = _run("--time-mode", "lockstep")
    assert nodes["replica"].params["control_rate"] == 1000.0
    copy = tmp_path / "profiles"
    shutil.copytree(PROFILES, copy)
    realtime = yaml.safe_load((copy / "realtime.yaml").read_text())
    realtime["control_rate_hz"] = 250.0
    (copy / "realtime.yaml").write_text(yaml.safe_dump(realtime))
    monkeypatch.setattr(run_profile, "PROFILES", copy)
    args, nodes = _run()
    assert nodes["replica"].params["control_rate"] == 250.0
    assert args.joint_state_rate == 500.0   # 250 Hz ticks fall on every second 500 Hz state
    _, nodes = _run("--control-rate", "100")   # the option still wins
    assert nodes["replica"].params["control_rate"] == 100.0


def test_the_paper_law_is_the_replicas_own_switch() -> None:
    _, nodes = _run("--paper-law")
    assert nodes["replica"].params["paper_law"] is True
    _, nodes = _run()
    assert "paper_law" not in nodes["replica"].params   # config/replica.yaml's false


def test_a_profile_of_ones_own_selects_layers_by_its_options_and_comes_last(tmp_path) -> None:
    path = tmp_path / "slow_lockstep.yaml"
    path.write_text(yaml.safe_dump({"description": "lockstep at 250 Hz, the paper's law",
                                    "options": {"time_mode": "lockstep", "paper_law": True},
                                    "control_rate_hz": 250.0, "niceness": {"planner": -5},
                                    "parameters": {"planner": {"use_sim_time": True}}}))
    args, nodes = _run("--profile", str(path))
    assert args.time_mode == "lockstep" and args.paper_law
    assert args.run_profile["layers"] == ["realtime", "lockstep", "paper_law", str(path)]
    assert nodes["replica"].params["control_rate"] == 250.0 and nodes["replica"].params["paper_law"] is True
    assert nodes["robot"].params["lockstep_subscribers"] == 2           # the lockstep layer's
    assert nodes["planner"].niceness == -5 and nodes["robot"].niceness == -15   # maps merge key by key
    args, _ = _run("--profile", str(path), "--time-mode", "realtime")   # the command line wins
    assert args.time_mode == "realtime" and args.run_profile["layers"][:2] == ["realtime", "paper_law"]


@pytest.mark.parametrize("content, words", [
    ({"contol_rate_hz": 300.0}, "unknown key 'contol_rate_hz' in profile bad; did you mean 'control_rate_hz'?"),
    ({"parameters": {"replcia": {"control_rate": 300.0}}}, "did you mean 'replica'?"),
    ({"options": {"time_mod": "lockstep"}}, "did you mean 'time_mode'?"),
    ({"options": {"time_mode": "lockstpe"}}, "did you mean 'lockstep'?"),
    ({"node_groups": [["channel_forward", "chanel_backward"]]}, "did you mean 'channel_backward'?"),
    ({"control_rate_hz": "fast"}, "control_rate_hz: int or float needed"),
    ({"use_sim_time": 1}, "use_sim_time: bool needed"),
    ({"timing_bounds": {"real_time_factr": 0.9}}, "in profile bad timing_bounds; did you mean 'real_time_factor'?"),
    ({"timing_bounds": {"loop_rate_fraction": 90}}, "timing_bounds loop_rate_fraction: a share in (0, 1] needed"),
    ({"timing_bounds": {"recorded_fraction": 0}}, "timing_bounds recorded_fraction: a share in (0, 1] needed"),
    ({"stations": {"mastr": {}}}, "in profile bad stations; did you mean 'master'?"),
    ({"stations": {"master": {"adress": "10.0.0.1"}}}, "did you mean 'address'?"),
    ({"stations": {"robot": {"address": "10.0.0.300"}}}, "stations robot address: an IPv4 address needed"),
    ({"stations": {"master": {"nodes": ["haptic_devise"]}}}, "did you mean 'haptic_device'?"),
    ({"stations": {"prefix_length": 40}}, "stations prefix_length: 8-30 needed"),
    ({"stations": {"namespace_prefix": "Lab-"}}, "stations namespace_prefix: 1-32 characters"),
    ({"stations": {"link_streams": ["master/teleop_command"]}}, "stations link_streams: a topic name"),
    ({"cpu_placement": {"replicа": 0}}, "did you mean 'replica'?"),
    ({"cpu_placement": {"replica": -1}}, "cpu_placement replica: a CPU index >= 0 needed"),
    ({"cpu_placement": {"replica": "0"}}, "cpu_placement replica: int needed"),
])
def test_a_misspelt_or_mistyped_profile_is_refused_in_one_line(tmp_path, capsys, content, words) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(content))
    with pytest.raises(run_profile.ProfileError) as refusal:
        run_profile.read_layer(path)
    assert words in str(refusal.value)
    assert teleop_launcher.main(["--profile", str(path), "--out", str(tmp_path / "run")]) == EXIT_REFUSED
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and words in err, err
    assert not (tmp_path / "run").exists()   # refused before anything was made


def test_an_unknown_profile_name_is_refused_naming_the_nearest(tmp_path, capsys) -> None:
    assert teleop_launcher.main(["--profile", "lockstop", "--out", str(tmp_path / "run")]) == EXIT_REFUSED
    assert "did you mean 'lockstep'?" in capsys.readouterr().err


@pytest.mark.parametrize("stations, words", [
    ({"master": {"nodes": ["haptic_device", "fd_adapter", "master", "channel_backward", "keyboard_operator",
                           "recorder_master", "planner"]}}, "planner in both stations"),
    ({"robot": {"nodes": ["robot", "recorder", "replica", "channel_forward"]}}, "command_relay, planner in neither"),
    ({"robot": {"address": "198.51.100.1"}}, "both stations at 198.51.100.1"),
    ({"robot": {"address": "198.51.101.2"}}, "198.51.101.2 is not in 198.51.100.0/24"),
])
def test_a_two_station_layout_that_does_not_hold_together_is_refused(tmp_path, capsys, stations, words) -> None:
    """Each layer's values are checked as it is read; the merged layout of a two-station run as a whole."""
    path = tmp_path / "layout.yaml"
    path.write_text(yaml.safe_dump({"options": {"two_stations": True}, "stations": stations}))
    assert teleop_launcher.main(["--profile", str(path), "--out", str(tmp_path / "run")]) == EXIT_REFUSED
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and words in err, err


def test_the_starved_verdicts_bounds_are_the_profiles(tmp_path, monkeypatch) -> None:
    """The bounds of "the machine was starved" (launch_timing.py) come from realtime.yaml and follow it; the real-time
    factor's is the report's own target (one value, fic_teleop_tools/report/metrics.py) until a profile sets it."""
    from fic_teleop_tools.report.metrics import TARGETS

    args, _ = _run()
    bounds = TimingBounds.from_profile(args.run_profile)
    realtime = yaml.safe_load((PROFILES / "realtime.yaml").read_text())["timing_bounds"]
    assert "real_time_factor" not in realtime and bounds.real_time_factor == TARGETS["real_time_factor"][1]
    assert (bounds.loop_rate_fraction, bounds.recorded_fraction) == \
        (realtime["loop_rate_fraction"], realtime["recorded_fraction"])
    slow = {"real_time_factor": 0.8}
    assert timing_verdict(slow, {}, None, bounds).starved
    copy = tmp_path / "profiles"
    shutil.copytree(PROFILES, copy)
    realtime["real_time_factor"] = 0.75
    whole = yaml.safe_load((copy / "realtime.yaml").read_text())
    (copy / "realtime.yaml").write_text(yaml.safe_dump({**whole, "timing_bounds": realtime}))
    monkeypatch.setattr(run_profile, "PROFILES", copy)
    args, _ = _run()
    assert not timing_verdict(slow, {}, None, TimingBounds.from_profile(args.run_profile)).starved


def test_in_lockstep_the_replica_follows_the_robots_step_clock_and_the_others_a_500_hz_clock(tmp_path) -> None:
    _, nodes = _run("--time-mode", "lockstep")
    robot = nodes["robot"].params
    assert robot["step_clock_topic"] == "/sim/step_clock" and robot["lockstep_clock_rate_hz"] == 500.0
    assert nodes["replica"].remaps == {"/clock": "/sim/step_clock"}
    # Every follower's periods are whole multiples of the /clock period, so its callbacks keep their simulated times.
    clock_period_ms = 1000.0 / robot["lockstep_clock_rate_hz"]
    for node, file, keys in (("master", "master.yaml", ("control_rate", "network_rate")),
                             ("planner", "planner.yaml", ("publish_rate",)),
                             ("haptic_device", "haptic_device.yaml", ("publish_rate_hz",)),
                             ("channel_forward", "channel.yaml", ("delivery_rate_hz",))):
        sections = teleop_launcher.file_sections(teleop_launcher.CONFIG / file)
        values = {**sections.get("/**", {}), **sections.get(node, {}), **nodes[node].params}
        for key in keys:
            multiple = 1000.0 / values[key] / clock_period_ms
            assert multiple == pytest.approx(round(multiple)), (node, key, values[key])
    _, realtime = _run()
    assert "/clock" not in realtime["replica"].remaps
    # A profile that turns the step clock off leaves the replica on /clock.
    layer = tmp_path / "no_step_clock.yaml"
    layer.write_text(yaml.safe_dump({"parameters": {"robot": {"step_clock_topic": ""}}}))
    _, nodes = _run("--time-mode", "lockstep", "--profile", str(layer))
    assert "/clock" not in nodes["replica"].remaps


def test_in_lockstep_the_simulation_waits_for_the_channels_heartbeats_as_for_its_other_peers() -> None:
    _, nodes = _run("--time-mode", "lockstep")
    peers = nodes["robot"].params["lockstep_peers"]
    assert {"/channel_forward/heartbeat", "/channel_backward/heartbeat", "/master/teleop_command"} <= set(peers)
    assert nodes["channel_forward"].params["lockstep_heartbeat"] is True
    assert nodes["channel_backward"].params["lockstep_heartbeat"] is True
    _, realtime = _run()
    assert "lockstep_heartbeat" not in realtime["channel_forward"].params
    _, unbarred = _run("--time-mode", "lockstep", "--no-peer-barrier")
    assert "lockstep_peers" not in unbarred["robot"].params
