"""A starved run's report still gives its safety figures, or says why it cannot (fic_teleop_tools/report/metrics.py
limit_counts and not_measured; the launcher's fallback on the replica's own stop line, launch_supervision.py).

Measured: under a CPU quota of half a core the recorder took nothing of the replica's streams before the graph
stopped (0.4 s of a 10 s run in the bag), and the report's error and limit-violation figures were n/a without a word.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

BASE_NS = 50 * 1_000_000_000
WALL0_NS = 1_700_000_000 * 1_000_000_000


def _bag(path: Path, *, seconds: float, limit_status_ticks: int | None = None, replica_record: dict | None = None,
         poses_until: float = 0.0) -> Path:
    """A bag of ``seconds`` of /clock and /joint_states at 100 Hz; optionally the replica's LimitStatus counters
    (``limit_status_ticks`` ticks, 1 violation), its "replica" /diagnostics record, and its poses until
    ``poses_until`` s."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from fic_teleop_tools.recording.bag_writer import find_interface_file

    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg(find_interface_file("fic_teleop_msgs/msg/LimitStatus").read_text(),
                                      "fic_teleop_msgs/msg/LimitStatus"))
    T = store.types

    def time_of(ns: int):
        return T["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def header(ns: int):
        return T["std_msgs/msg/Header"](stamp=time_of(ns), frame_id="panda_link0")

    messages = []
    for k in range(round(seconds * 100)):
        ns = BASE_NS + k * 10_000_000
        messages.append((ns, "/clock", T["rosgraph_msgs/msg/Clock"](clock=time_of(ns))))
        messages.append((ns, "/joint_states", T["sensor_msgs/msg/JointState"](
            header=header(ns), name=["panda_joint1"], position=np.array([0.0]), velocity=np.array([]),
            effort=np.array([]))))
        if k * 0.01 < poses_until:
            for topic in ("/replica/desired_pose", "/replica/tcp_pose"):
                messages.append((ns, topic, T["geometry_msgs/msg/PoseStamped"](header=header(ns), pose=T[
                    "geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=0.3, y=0.0, z=0.4),
                                              orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0,
                                                                                             w=1.0)))))
    if limit_status_ticks is not None:
        messages.append((BASE_NS, "/replica/limit_status", T["fic_teleop_msgs/msg/LimitStatus"](
            header=header(BASE_NS), shaping=0, violations=1, torque_change=0.0, torque_ratio=np.zeros(7),
            torque_rate_ratio=np.zeros(7), joint_velocity_ratio=np.zeros(7), joint_position_margin=np.zeros(7),
            tcp_speed=0.0, ticks=limit_status_ticks, shaped_ticks=3, violation_ticks=1)))
    if replica_record is not None:
        KeyValue, Status = T["diagnostic_msgs/msg/KeyValue"], T["diagnostic_msgs/msg/DiagnosticStatus"]
        status = Status(level=0, name="replica", message="running", hardware_id="fic_teleop_replica",
                        values=[KeyValue(key=key, value=value) for key, value in replica_record.items()])
        last = messages[-1][0]
        messages.append((last, "/diagnostics", T["diagnostic_msgs/msg/DiagnosticArray"](header=header(last),
                                                                                         status=[status])))
    messages.sort(key=lambda m: m[0])
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {}
        for ns, topic, message in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, message.__msgtype__, typestore=store)
            writer.write(connections[topic], WALL0_NS + ns - BASE_NS, store.serialize_cdr(message, message.__msgtype__))
    return path


def _metrics(bag: Path) -> dict:
    from fic_teleop_tools.report import ReportSettings, analyse, load_bag

    return analyse(load_bag(bag), ReportSettings(warmup_s=2.0)).metrics


def test_the_limit_counts_come_from_the_replicas_diagnostics_when_the_bag_has_no_limit_status(tmp_path: Path) -> None:
    record = {"ticks": "377", "violation_ticks": "2", "shaped_ticks": "70"}
    m = _metrics(_bag(tmp_path / "bag", seconds=0.4, replica_record=record))
    assert (m["limit_violations"], m["limit_shaped_ticks"]) == (2, 70)
    assert m["limit_counters_source"] == "/diagnostics (replica)"
    assert m["targets"]["limit_violations"]["met"] is False
    # the error cannot be given, and the report says why
    assert m["free_motion_error_max_m"] is None
    assert m["not_measured"]["free_motion_error_max_m"].startswith("no tracking-error source in the bag")
    assert "the bag holds 0.4 s of simulated time" in m["not_measured"]["free_motion_error_max_m"]
    assert "limit_violations" not in m["not_measured"]


def test_the_counters_that_counted_more_ticks_win(tmp_path: Path) -> None:
    """A recorder that kept only the start of the LimitStatus stream: the replica's last record counted more."""
    later = _metrics(_bag(tmp_path / "later", seconds=3.0, limit_status_ticks=40,
                          replica_record={"ticks": "1500", "violation_ticks": "4", "shaped_ticks": "9"}))
    assert (later["limit_violations"], later["limit_counters_source"]) == (4, "/diagnostics (replica)")
    earlier = _metrics(_bag(tmp_path / "earlier", seconds=3.0, limit_status_ticks=1600,
                            replica_record={"ticks": "1500", "violation_ticks": "0", "shaped_ticks": "9"}))
    assert (earlier["limit_violations"], earlier["limit_counters_source"]) == (1, "/replica/limit_status")


def test_a_bag_without_counters_or_after_the_warm_up_says_why(tmp_path: Path) -> None:
    m = _metrics(_bag(tmp_path / "bag", seconds=3.0, poses_until=1.5))
    assert m["limit_violations"] is None and m["not_measured"]["limit_violations"].startswith("no limit counters")
    assert m["not_measured"]["free_motion_error_rms_m"].startswith("all 150 tracking-error samples lie in the 2 s "
                                                                     "warm-up")
    from fic_teleop_tools.report.report import summary_table
    assert "n/a limit_violations: no limit counters in the bag" in summary_table(m)


def test_the_launcher_takes_the_replicas_own_counters_from_its_stop_line(tmp_path: Path) -> None:
    from fic_teleop_bringup.launch_supervision import fill_limit_counters
    from fic_teleop_replica.replica_node import STOPPED_LINE

    (tmp_path / "replica.log").write_text(
        "[INFO] [1.0] [replica]: replica ready\n"
        f"[INFO] [2.0] [replica]: {STOPPED_LINE}{{'input_safe_hold': 'no', 'ticks': '377', 'shaped_ticks': '70', "
        "'violation_ticks': '3', 'master_watchdog': \"stale (holding x_d')\"}\n")
    metrics = {"limit_violations": None, "not_measured": {"limit_violations": "no limit counters in the bag"}}
    assert fill_limit_counters(metrics, tmp_path)
    assert (metrics["limit_violations"], metrics["limit_shaped_ticks"]) == (3, 70)
    assert metrics["limit_counters_source"] == "the replica's log at its stop (377 control ticks)"
    assert metrics["not_measured"] == {}
    assert not fill_limit_counters({"limit_violations": 0}, tmp_path)        # the bag's own figure stands
    assert not fill_limit_counters({"limit_violations": None}, tmp_path / "elsewhere")   # no log: still unknown
