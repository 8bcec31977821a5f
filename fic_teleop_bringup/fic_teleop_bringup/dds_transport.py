"""The DDS transport of the nodes the launcher starts on one host: the run profile's ``dds_profile`` (a Fast DDS XML
file in config/): loopback UDP without shared memory for the realtime graph (config/fastdds_loopback_udp.xml says why:
docs/RESULTS.md, "Start-up stall"), shared memory plus loopback UDP for lockstep (config/fastdds_lockstep.xml); both
keep every packet on the host and announce each participant 30 times at start (docs/RESULTS.md, "Starvation":
discovery at start).

The profile is applied only where the user has not chosen a DDS setup of their own: no Fast DDS profile file in the
environment and a discovery range that is unset or LOCALHOST (the single-host default). A user's own profile file, a
SUBNET or SYSTEM_DEFAULT range (a real robot on the network), another RMW, or a two-station run (which writes its
own profile, two_stations.py) is left as it is, and the run says which transport it used.
"""
from __future__ import annotations

from collections.abc import MutableMapping
from pathlib import Path

PROFILE_VARIABLES = ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE")
RANGE_VARIABLE = "ROS_AUTOMATIC_DISCOVERY_RANGE"
# rmw_fastrtps replaces a profile's transports by its own (shared memory plus UDP) under LOCALHOST; under SUBNET it
# keeps them, and the profile itself keeps everything on 127.0.0.1.
PROFILE_RANGE = "SUBNET"


def apply(environ: MutableMapping[str, str], profile: Path | None) -> str:
    """Set ``environ`` (the launcher's, inherited by every node) to ``profile`` where the user chose nothing else;
    return one line saying which transport the nodes use."""
    if profile is None:
        return "DDS: the RMW's defaults (the run profile names no dds_profile)"
    rmw = environ.get("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    if rmw != "rmw_fastrtps_cpp":
        return f"DDS: {rmw} with its own defaults (the dds_profile {profile.name} is for Fast DDS)"
    given = next((environ[name] for name in PROFILE_VARIABLES if environ.get(name)), None)
    if given:
        return f"DDS: your Fast DDS profile {given}"
    discovery_range = environ.get(RANGE_VARIABLE, "LOCALHOST")
    if discovery_range != "LOCALHOST":
        return f"DDS: the RMW's transports with {RANGE_VARIABLE}={discovery_range} (yours)"
    if not profile.is_file():
        raise FileNotFoundError(f"the run profile's dds_profile {profile} does not exist")
    for name in PROFILE_VARIABLES:
        environ[name] = str(profile)
    environ[RANGE_VARIABLE] = PROFILE_RANGE
    return f"DDS: {profile.name} (this host only; your own FASTRTPS_DEFAULT_PROFILES_FILE replaces it)"
