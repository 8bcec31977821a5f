"""The replica node watching its own loop (fic_core.loop_health), as a real process: joint states that stop for
200 ms (the control ticks that far apart) put it into its hold, said in one line and at once on /diagnostics as
the "replica loop health" status (ERROR, with its state age, tick gap and hold counts); the law comes back after
healthy ticks, said too; every torque names the joint state it was computed on (fic_core.command_stamp)."""
from __future__ import annotations

import pytest
from conftest import CONFIG
from replica_side import Robot

rclpy = pytest.importorskip("rclpy")

from fic_core.command_stamp import stamp_ns  # noqa: E402

STATUS = "replica loop health"


def test_a_gap_in_the_loop_holds_and_is_said_on_diagnostics(start_node, ros_env, rclpy_context) -> None:
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import Float64MultiArray

    replica = start_node("fic_teleop_replica", "replica_node", params_file=CONFIG / "replica.yaml",
                         params={"control_rate": 250.0, "diagnostics_rate": 5.0})
    assert replica.wait_for_output("waiting for /joint_states", timeout=60.0), replica.output()
    robot = Robot(rclpy_context)
    record = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=5000)
    health: list = []
    labels: list[str] = []
    robot.node.create_subscription(DiagnosticArray, "/diagnostics",
                                   lambda m: health.extend(s for s in m.status if s.name == STATUS), record)
    robot.node.create_subscription(Float64MultiArray, "/effort_controller/commands",
                                   lambda m: labels.extend(d.label for d in m.layout.dim), record)
    robot.wait_for_replica()
    robot.publish_joint_states(1.0)
    robot.spin(0.2)                     # no joint state for 200 ms: the next tick comes 200 ms after the last
    assert robot.publish_until(lambda: "takes over from the hold" in replica.output(), timeout=60.0), \
        replica.output()
    robot.spin_until(lambda: any(int(dict((v.key, v.value) for v in s.values)["holds"]) >= 1 and
                                 s.level != DiagnosticStatus.ERROR for s in health), 10.0)
    log = replica.output()
    assert "replica loop unhealthy: control ticks" in log and "ms apart" in log, log
    held = [s for s in health if s.level == DiagnosticStatus.ERROR]
    assert held and all(s.message.startswith("holding: ") for s in held), [s.message for s in health]
    # (A loaded machine may add holds of its own, 40-50 ms gaps of this side's pacing: the 200 ms one is counted.)
    values = [{v.key: v.value for v in s.values} for s in health]
    assert all({"state_age_ms", "tick_gap_ms", "holds", "held_ticks"} <= set(v) for v in values)
    assert any(float(v["max_tick_gap_ms"]) >= 150.0 and int(v["holds"]) >= 1 and int(v["held_ticks"]) >= 1
               for v in values), values[-1]
    # Every torque names its joint state, one of those published.
    published = set(robot.state_stamps)
    assert labels and all(stamp_ns(label) in published for label in labels), labels[:3]
    assert replica.stop(timeout=15.0) == 0, replica.log_path.read_text()
