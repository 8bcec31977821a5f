"""The launcher's DDS transport: the run profile's Fast DDS profile only where the user chose nothing else."""
from __future__ import annotations

from pathlib import Path

import pytest

from fic_teleop_bringup import dds_transport
from fic_teleop_bringup.run_profile import profile_path, read_layer
from fic_teleop_bringup.workspace import CONFIG


@pytest.fixture()
def profile(tmp_path: Path) -> Path:
    path = tmp_path / "fastdds.xml"
    path.write_text("<dds/>")
    return path


def test_the_default_environment_gets_the_profile_and_a_range_that_keeps_its_transports(profile):
    environ: dict[str, str] = {}
    line = dds_transport.apply(environ, profile)
    assert environ["FASTRTPS_DEFAULT_PROFILES_FILE"] == environ["FASTDDS_DEFAULT_PROFILES_FILE"] == str(profile)
    assert environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SUBNET"
    assert profile.name in line


@pytest.mark.parametrize("given", [
    {"FASTRTPS_DEFAULT_PROFILES_FILE": "/mine.xml"},
    {"FASTDDS_DEFAULT_PROFILES_FILE": "/mine.xml"},
    {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"},
    {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT"},
    {"RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"},
])
def test_a_users_own_choice_is_left_as_it_is_and_named(profile, given):
    environ = dict(given)
    line = dds_transport.apply(environ, profile)
    assert environ == given
    assert any(value in line for value in given.values())


def test_localhost_set_explicitly_is_the_default_single_host_case(profile):
    environ = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    dds_transport.apply(environ, profile)
    assert environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SUBNET"


def test_no_profile_leaves_the_environment_alone():
    environ: dict[str, str] = {}
    assert "defaults" in dds_transport.apply(environ, None)
    assert environ == {}


def test_a_missing_profile_file_is_refused_in_one_line(tmp_path):
    with pytest.raises(FileNotFoundError, match="dds_profile"):
        dds_transport.apply({}, tmp_path / "absent.xml")


def test_the_default_run_profile_names_the_loopback_udp_file_which_has_no_shared_memory():
    name = read_layer(profile_path("realtime"))["dds_profile"]
    text = (CONFIG / name).read_text()
    assert "<type>UDPv4</type>" in text and "<address>127.0.0.1</address>" in text
    assert "<useBuiltinTransports>false</useBuiltinTransports>" in text and "SHM" not in text


@pytest.mark.parametrize("run_profile", ["realtime", "lockstep"])
def test_each_single_host_profile_stays_on_the_host_and_announces_30_times_at_start(run_profile):
    """Both single-host graphs load a profile that keeps every packet on 127.0.0.1 (or shared memory) and announces each
    participant 30 times, 100 ms apart: with Fast DDS's 5 a node that came up late met another 3 s later, and a lockstep
    run lost its first seconds of commands (config/fastdds_lockstep.xml)."""
    import xml.etree.ElementTree as ElementTree

    name = read_layer(profile_path(run_profile))["dds_profile"]
    namespace = {"dds": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}
    root = ElementTree.parse(CONFIG / name).getroot()
    participant = root.find("dds:profiles/dds:participant[@is_default_profile='true']", namespace)
    announcements = participant.find("dds:rtps/dds:builtin/dds:discovery_config/dds:initialAnnouncements", namespace)
    assert int(announcements.find("dds:count", namespace).text) == 30
    assert int(announcements.find("dds:period/dds:nanosec", namespace).text) == 100_000_000
    assert participant.find("dds:rtps/dds:useBuiltinTransports", namespace).text == "false"
    for descriptor in root.findall("dds:profiles/dds:transport_descriptors/dds:transport_descriptor", namespace):
        kind = descriptor.find("dds:type", namespace).text
        assert kind in ("SHM", "UDPv4"), kind
        if kind == "UDPv4":
            addresses = descriptor.findall("dds:interfaceWhiteList/dds:address", namespace)
            assert [address.text for address in addresses] == ["127.0.0.1"]


def test_the_two_station_profile_has_no_shared_memory():
    """UDP only within a station too: with shared memory beside it, Fast DDS opened a late reader's shared-memory
    port under a writer's lock (333 ms) and the replica held the arm at start in 4 of 10 two-station runs."""
    text = (CONFIG / "fastdds_two_stations.xml").read_text()
    assert "<type>UDPv4</type>" in text and "<type>SHM</type>" not in text
    assert "<useBuiltinTransports>false</useBuiltinTransports>" in text
