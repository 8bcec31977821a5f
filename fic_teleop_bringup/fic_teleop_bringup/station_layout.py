"""What runs where in a two-station run: the run profile's ``stations`` (fic_teleop_bringup/profiles/two_stations.yaml,
docs/DEPLOYMENT.md) as one object, read by the deployment (two_stations.py) and by the analysis of its link
(station_analysis.py), and the one error a two-station run is refused with."""
from __future__ import annotations

from dataclasses import dataclass, field


class StationError(RuntimeError):
    """A two-station run cannot start; the message is the one line to print."""


@dataclass(frozen=True)
class StationLayout:
    """The run profile's ``stations`` (profiles/two_stations.yaml; run_profile.check_stations_whole has checked it):
    which node runs in which station, the namespaces' prefix, the link's addresses and the streams it is for."""

    namespace_prefix: str
    prefix_length: int
    master_address: str
    robot_address: str
    master_nodes: frozenset[str]
    robot_nodes: frozenset[str]
    link_streams: tuple[str, ...]
    master_topics: tuple[str, ...] = ()                     # recorded in the master station (bag_master/)
    master_remaps: dict[str, str] = field(default_factory=dict)
    robot_not_recorded: tuple[str, ...] = ()                # left out of the robot station's recorder as well

    @classmethod
    def from_profile(cls, profile: dict) -> "StationLayout":
        stations = profile["stations"]
        master, robot = stations["master"], stations["robot"]
        return cls(namespace_prefix=stations["namespace_prefix"], prefix_length=stations["prefix_length"],
                   master_address=master["address"], robot_address=robot["address"],
                   master_nodes=frozenset(master["nodes"]), robot_nodes=frozenset(robot["nodes"]),
                   link_streams=tuple(stations["link_streams"]), master_topics=tuple(master.get("topics", ())),
                   master_remaps=dict(master.get("remaps", {})),
                   robot_not_recorded=tuple(robot.get("not_recorded", ())))

    @property
    def robot_station_excluded(self) -> set[str]:
        """What the robot station's recorder leaves out of its topic table (it would cross the link)."""
        return set(self.master_topics) | set(self.robot_not_recorded)

    def station_of(self, node_name: str) -> str:
        """The station of a node, or of a node group ("a+b", fic_teleop_bringup.node_groups): its members' one."""
        if "+" in node_name:
            stations = {self.station_of(member) for member in node_name.split("+")}
            if len(stations) > 1:
                raise StationError(f"node group {node_name} spans both stations: a process runs in one")
            return stations.pop()
        if node_name in self.master_nodes:
            return "master"
        if node_name in self.robot_nodes:
            return "robot"
        raise StationError(f"node {node_name} is in neither station of the profile's stations")
