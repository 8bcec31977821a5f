"""The achieved rate of every loop (fic_teleop_tools/report/loop_rates.py) from bags written with known rates: the
default graph's streams, the driver twins' streams (/franka/joint_states, /fd/ee_pose) and a two-station run whose
master station's loops are in its own bag, over that bag's own clock."""
from __future__ import annotations

from pathlib import Path

import pytest

SECOND = 1_000_000_000


def _bag(path: Path, rates: dict[str, float], seconds: float = 10.0, offset_ns: int = 0) -> Path:
    """A bag holding each topic at its rate [Hz] for ``seconds``, its receive times shifted by ``offset_ns``."""
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Empty

    from fic_teleop_tools.recording.bag_writer import BagWriter

    writer = BagWriter(path)
    payload = serialize_message(Empty())
    events = []
    for topic, rate in rates.items():
        writer.add_topic(topic, "std_msgs/msg/Empty")
        events += [(round(k * SECOND / rate) + offset_ns, topic) for k in range(int(seconds * rate))]
    for time_ns, topic in sorted(events):
        writer.write(topic, payload, time_ns)
    writer.finish()
    return path


def _params(run_dir: Path, robot: dict, device: dict) -> None:
    params = run_dir / "params"
    params.mkdir(parents=True, exist_ok=True)
    for name, node, values in (("robot.yaml", "/robot", robot), ("haptic_device.yaml", "/haptic_device", device)):
        lines = [f"{node}:", "  ros__parameters:"] + [f"    {key}: {value}" for key, value in values.items()]
        (params / name).write_text("\n".join(lines) + "\n")


DEFAULT_STREAMS = {"/joint_states": 1000.0, "/haptic/pose": 250.0, "/haptic/wrench_command": 200.0,
                   "/master/teleop_command": 100.0, "/planner/desired_pose": 100.0,
                   "/effort_controller/commands": 800.0, "/replica/teleop_command": 100.0}


def test_the_default_graph_rates_against_config(tmp_path: Path) -> None:
    from fic_teleop_tools.report.loop_rates import loop_rates

    rates = loop_rates(_bag(tmp_path / "bag", DEFAULT_STREAMS), tmp_path)
    assert rates["robot physics"]["fraction"] == pytest.approx(1.0, abs=0.01)
    assert rates["master force"]["fraction"] == pytest.approx(0.8, abs=0.01)        # 200 of 250 Hz
    # 800 of config/replica.yaml's 1000 Hz
    assert rates["replica control"]["fraction"] == pytest.approx(0.8, abs=0.01)
    assert rates["haptic device"]["topic"] == "/haptic/pose"


def test_the_twins_are_judged_on_the_drivers_streams(tmp_path: Path) -> None:
    from fic_teleop_tools.report.loop_rates import loop_rates

    # The twins: /joint_states is franka's 30 Hz joint_state_publisher, the physics shows on /franka/joint_states;
    # the device driver publishes /fd/ee_pose at its 1 kHz and the adapter /haptic/pose at 250 Hz.
    streams = {**DEFAULT_STREAMS, "/joint_states": 30.0, "/franka/joint_states": 900.0, "/fd/ee_pose": 600.0}
    _params(tmp_path, {"driver_interface": '"franka_ros2"'},
            {"driver_interface": '"forcedimension"', "publish_rate_hz": 1000.0})
    rates = loop_rates(_bag(tmp_path / "bag", streams), tmp_path)
    assert rates["robot physics"]["topic"] == "/franka/joint_states"
    assert rates["robot physics"]["fraction"] == pytest.approx(0.9, abs=0.01)
    assert rates["haptic device"]["topic"] == "/fd/ee_pose"
    assert rates["haptic device"]["fraction"] == pytest.approx(0.6, abs=0.01)


def test_a_two_station_run_reads_the_master_stations_bag_on_its_own_clock(tmp_path: Path) -> None:
    from fic_teleop_tools.report.loop_rates import loop_rates

    master_side = ("/haptic/pose", "/haptic/wrench_command", "/master/teleop_command")
    robot = {topic: rate for topic, rate in DEFAULT_STREAMS.items() if topic not in master_side}
    master = {topic: DEFAULT_STREAMS[topic] for topic in master_side}
    _bag(tmp_path / "bag", robot)
    # the master station's clock 37 s off the robot station's: each rate over its own bag's span
    _bag(tmp_path / "bag_master", master, offset_ns=37 * SECOND)
    rates = loop_rates(tmp_path / "bag", tmp_path)
    assert rates["haptic device"]["fraction"] == pytest.approx(1.0, abs=0.01)
    assert rates["master force"]["fraction"] == pytest.approx(0.8, abs=0.01)
    assert rates["master network"]["fraction"] == pytest.approx(1.0, abs=0.01)
    assert rates["replica control"]["fraction"] == pytest.approx(0.8, abs=0.01)
    # without the master station's bag those loops are not seen at all
    (tmp_path / "bag_master").rename(tmp_path / "elsewhere")
    assert loop_rates(tmp_path / "bag", tmp_path)["haptic device"]["fraction"] == 0.0
