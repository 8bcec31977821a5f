"""``scripts/report.sh <bag>`` prints the session's two verdicts with their reasons (fic_teleop_tools.report and
fic_teleop_tools.verdict.run_verdict), on small synthetic bags written with rosbags' own writer:

- ``oscillating``: 12 s at 0.2 s one-way, x_d - x_R along x a 20 mm sine at 1.3 s (a limit cycle), no limit
  violation, the robot's reflex untouched and no safe hold: NOT STABLE (a sustained oscillation of x_d - x_R at
  1.3 s), SAFE;
- ``quiet``: the same with a 1 mm error, a joint at 1.2 rad/s, and the robot's diagnostics naming a reflex trip:
  STABLE, NOT SAFE (1 velocity reflex trip).
"""
from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

DURATION_MS, DELAY = 12_000, 0.2
BASE_NS = 10 * 1_000_000_000


def write_bag(folder: Path, amplitude: float, reflex: str) -> Path:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from fic_teleop_tools.recording.bag_writer import find_interface_file

    store = get_typestore(Stores.ROS2_JAZZY)
    for name in ("FicState", "LimitStatus"):
        type_name = f"fic_teleop_msgs/msg/{name}"
        store.register(get_types_from_msg(find_interface_file(type_name).read_text(), type_name))
    T = store.types
    Time, Header = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    Point, Quaternion = T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"]
    Pose = T["geometry_msgs/msg/Pose"]
    Vector3, Wrench = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Wrench"]
    Status, KeyValue = T["diagnostic_msgs/msg/DiagnosticStatus"], T["diagnostic_msgs/msg/KeyValue"]

    def header(ns: int):
        return Header(stamp=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000), frame_id="panda_link0")

    def pose(ns: int, x: float):
        return T["geometry_msgs/msg/PoseStamped"](header=header(ns), pose=Pose(
            position=Point(x=x, y=0.1, z=0.4), orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)))

    messages = []
    for k in range(DURATION_MS):
        ns, t = BASE_NS + k * 1_000_000, k / 1000
        messages.append((ns, "/joint_states", T["sensor_msgs/msg/JointState"](
            header=header(ns), name=[f"panda_joint{j + 1}" for j in range(7)], position=np.zeros(7),
            velocity=np.array([1.2 * np.sin(t), 0, 0, 0, 0, 0, 0], dtype=float), effort=np.zeros(7))))
        if k % 4 == 0:
            messages.append((ns, "/ft_sensor/wrench", T["geometry_msgs/msg/WrenchStamped"](
                header=header(ns), wrench=Wrench(force=Vector3(x=0.0, y=0.0, z=0.0),
                                                 torque=Vector3(x=0.0, y=0.0, z=0.0)))))
        if k % 10 == 0:
            error = amplitude * np.sin(2 * np.pi * t / 1.3)
            messages.append((ns, "/replica/desired_pose", pose(ns, 0.3)))
            messages.append((ns, "/replica/tcp_pose", pose(ns, 0.3 - error)))
            messages.append((ns, "/replica/fic_state", T["fic_teleop_msgs/msg/FicState"](
                header=header(ns), controller="fic", phase=np.zeros(6, dtype=np.uint8),
                error=np.array([error, 0, 0, 0, 0, 0], dtype=float), latched_max_error=np.zeros(6), force=np.zeros(6),
                stored_energy=np.zeros(6), total_energy=0.5 * 200.0 * error ** 2, master_stamp=header(ns).stamp,
                master_age=0.0, master_stale=False, port_work=np.zeros(6), passivity_margin=np.zeros(6),
                passivity_margin_min=0.0, passivity_violation_ticks=0)))
            messages.append((ns, "/replica/limit_status", T["fic_teleop_msgs/msg/LimitStatus"](
                header=header(ns), shaping=0, violations=0, torque_change=0.0, torque_ratio=np.zeros(7),
                torque_rate_ratio=np.zeros(7), joint_velocity_ratio=np.zeros(7), joint_position_margin=np.zeros(7),
                tcp_speed=0.0, ticks=k + 1, shaped_ticks=0, violation_ticks=0)))
        if k % 1000 == 999:
            robot = Status(level=0, name="robot_sim", message="", hardware_id="panda_mujoco", values=[
                KeyValue(key="reflex", value=reflex if k > 6000 else ""),
                KeyValue(key="watchdog_engagements", value="0")])
            replica = Status(level=0, name="replica", message="", hardware_id="fic_teleop_replica",
                             values=[KeyValue(key="input_safe_hold", value="no")])
            messages.append((ns, "/diagnostics", T["diagnostic_msgs/msg/DiagnosticArray"](
                header=header(ns), status=[robot, replica])))
    messages.sort(key=lambda m: m[0])
    bag = folder / "bag"
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {}
        for ns, topic, message in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, message.__msgtype__, typestore=store)
            writer.write(connections[topic], ns, store.serialize_cdr(message, message.__msgtype__))
    return bag


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    root = tmp_path_factory.mktemp("verdict_bags")
    return {"oscillating": write_bag(root / "oscillating", 0.02, ""),
            "quiet": write_bag(root / "quiet", 0.001, "reflex: panda_joint4 moved at 2.5 rad/s")}


def test_the_report_prints_both_verdicts_with_reasons(bags, tmp_path):
    out = tmp_path / "report"
    result = subprocess.run([sys.executable, "-m", "fic_teleop_tools.report", str(bags["oscillating"]), "--out",
                             str(out),
                             "--delay", str(DELAY)], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "[verdict] one-way delay 0.2 s: NOT STABLE; SAFE" in result.stdout
    found = re.search(r"stable: sustained oscillation of x_d - x_R: ([0-9.]+) mm at ([0-9.]+) s", result.stdout)
    assert found and float(found[1]) == pytest.approx(20.0, abs=2.0) and float(found[2]) == pytest.approx(1.3, rel=0.05)
    verdict = json.loads((out / "verdict.json").read_text())
    assert verdict["stable"] is False and verdict["safe"] is True
    assert verdict["figures"]["oscillation"]["x_d - x_R"]["period"] == pytest.approx(1.3, rel=0.05)


def test_a_reflex_trip_in_the_diagnostics_makes_a_session_unsafe(bags, tmp_path, capsys):
    from fic_teleop_tools.report.__main__ import print_verdict

    print_verdict(bags["quiet"], tmp_path, DELAY)
    printed = capsys.readouterr().out
    assert "STABLE; NOT SAFE" in printed and "NOT STABLE" not in printed
    assert "safe: 1 velocity reflex trips" in printed
    assert json.loads((tmp_path / "verdict.json").read_text())["figures"]["joint_speed_ratio_max"] == \
        pytest.approx(1.2 / 2.175, rel=0.01)


def test_the_verdict_reads_the_reports_pass_as_the_experiments_decode_the_bag(bags):
    """The report reads the bag once for its figures and its verdict (load_bag with joint_velocities)."""
    from fic_teleop_tools.report.bag_data import load_bag
    from fic_teleop_tools.verdict.bag_series import read_run
    from fic_teleop_tools.verdict.run_verdict import VerdictInput

    bag = bags["oscillating"]
    data = load_bag(bag, joint_velocities=True)
    assert data.joint_velocity.shape == (len(data.series["/joint_states"]), 7)
    ours = VerdictInput.from_bag_data(data, one_way_delay=0.2)
    run = read_run(bag, joint_states=True)     # the experiments' own decoding of the same topics
    np.testing.assert_array_equal(ours.time, run.fic_time)
    np.testing.assert_allclose(ours.tracking_error, run.error)
    np.testing.assert_allclose(ours.controller_energy, run.total_energy)
    np.testing.assert_allclose(run.joint_velocity, data.joint_velocity[np.argsort(data.series["/joint_states"].stamp,
                                                                                  kind="stable")])
    assert ours.limit_violations == int(run.violation_ticks.max())
    assert ours.joint_speed is not None and ours.joint_speed.shape == (run.fic_time.size, 7)


def test_a_run_folders_quiet_tail_is_judged_by_its_free_response_and_left_out_of_the_error_figures(bags, tmp_path):
    """The launcher's --quiet-tail writes quiet_from (a stamp) in run.json: the report hands it to the verdict,
    which judges stability in the tail (the sine never dies: NOT STABLE there), and its error figures describe the
    task before it."""
    from fic_teleop_tools.report.__main__ import print_verdict
    from fic_teleop_tools.report.bag_data import load_bag
    from fic_teleop_tools.report.metrics import ReportSettings, analyse
    from fic_teleop_tools.verdict.run_record import quiet_from
    from fic_teleop_tools.verdict.run_verdict import VerdictInput

    run_dir = tmp_path / "run"
    run_dir.mkdir()
    tail_from = BASE_NS * 1e-9 + 2.5   # 9.5 s of tail: the verdict needs 1 s + 2 delays, then 8 s, at 0.2 s
    (run_dir / "run.json").write_text(json.dumps({"quiet_from": tail_from}))
    assert quiet_from(run_dir) == tail_from and quiet_from(tmp_path) is None and quiet_from(None) is None
    print_verdict(bags["oscillating"], tmp_path / "tail", DELAY, quiet_from(run_dir))
    verdict = json.loads((tmp_path / "tail" / "verdict.json").read_text())
    assert verdict["stable"] is False and verdict["figures"]["quiet_from_s"] == pytest.approx(tail_from)
    assert verdict["figures"]["tail_s"] >= verdict["figures"]["tail_needed_s"] - 0.1
    data = load_bag(bags["oscillating"])
    whole = analyse(data, ReportSettings(warmup_s=0.0)).metrics
    task = analyse(data, ReportSettings(warmup_s=0.0, quiet_from=tail_from)).metrics
    series = VerdictInput.from_bag_data(data, one_way_delay=DELAY)   # the error series and their stamps
    errors, before = np.linalg.norm(series.tracking_error, axis=1), series.time < tail_from
    assert task["free_motion_error_max_m"] == pytest.approx(errors[before].max(), rel=1e-6)
    assert task["free_motion_error_rms_m"] != pytest.approx(whole["free_motion_error_rms_m"], rel=1e-6)

