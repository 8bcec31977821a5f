"""fic_teleop_experiments.tools.torque_hold on a bag made here: how long each torque stayed applied on the arm's clock,
and the gaps between the states the commands were computed on."""
from __future__ import annotations

from pathlib import Path

import pytest

from fic_teleop_experiments.tools.torque_hold import summary, torque_holds


def _run(path: Path) -> Path:
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension, MultiArrayLayout

    from fic_core.command_stamp import label
    from fic_teleop_tools.recording.bag_writer import BagWriter

    writer = BagWriter(path / "bag")
    writer.add_topic("/joint_states", "sensor_msgs/msg/JointState")
    writer.add_topic("/effort_controller/commands", "std_msgs/msg/Float64MultiArray")
    # 1 kHz states; the applied torque changes every 2 ms, except one torque kept 82 ms (steps 100-182).
    for k in range(300):
        torque = 1.0 if 100 <= k < 182 else float(k // 2)
        state = JointState(position=[0.0] * 7, velocity=[0.0] * 7, effort=[torque] * 7)
        state.header.stamp.sec, state.header.stamp.nanosec = divmod(k * 1_000_000, 1_000_000_000)
        writer.write("/joint_states", serialize_message(state), k * 1_000_000)
    for k in (0, 10, 20, 86, 90):   # commands computed on states 10, 10, 66 and 4 ms apart
        layout = MultiArrayLayout(dim=[MultiArrayDimension(label=label(k * 1_000_000), size=7, stride=7)])
        writer.write("/effort_controller/commands", serialize_message(Float64MultiArray(layout=layout, data=[0.0] * 7)),
                     k * 1_000_000)
    writer.finish()
    return path


def test_a_torque_kept_82_ms_and_commands_on_states_66_ms_apart_are_counted(tmp_path: Path) -> None:
    applied, gaps = torque_holds(_run(tmp_path))
    assert applied.max() == pytest.approx(0.082) and summary(applied, 0.05)["over_50_ms"] == 1
    assert sorted(round(g * 1e3) for g in gaps) == [4, 10, 10, 66]
    assert summary(gaps, 0.05) == {"n": 4, "p50_ms": 10.0, "p99_ms": pytest.approx(64.3, abs=0.1), "max_ms": 66.0,
                                   "over_50_ms": 1}
    assert summary(gaps[:0], 0.05) == {"n": 0}
