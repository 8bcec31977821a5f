"""Hostile-but-fair probes of a running graph, from an outside process on its ROS domain (docs/SECURITY.md).

    python -m fic_teleop_experiments.tools.fault_probes teleop --offset 10 10 10 --seconds 1.5   # x_d' far outside the
    workspace python -m fic_teleop_experiments.tools.fault_probes teleop --stamp-offset 1e6                 # stamped
    10^6 s in the future python -m fic_teleop_experiments.tools.fault_probes teleop --epoch-zero                       #
    stamped at epoch 0 python -m fic_teleop_experiments.tools.fault_probes teleop --mode 7 --haptic-gain 50
    --velocity-gain 1e6 python -m fic_teleop_experiments.tools.fault_probes joint-states --seconds 2 --rate 500 --shift
    0.3   # a second writer

Run it with the graph's ROS_DOMAIN_ID (the launcher prints it). Each probe publishes for ``--seconds`` at
``--rate`` and exits; what the replica did is in its log, on /diagnostics and in the bag. The node tests run these
same probes (test/nodes/test_input_authority_probes.py); docs/RESULTS.md has the fault table.
"""
from __future__ import annotations

import argparse
import sys
import time

SPOOF_FRAME = "fault_probe"  # header.frame_id of every probe message, so a test can tell them from the robot's
ACK_TIMEOUT_S = 10.0         # how long a probe waits for its victim to acknowledge what it sent


def _publish_for(node, publisher, make_message, seconds: float, rate: float) -> int:
    import rclpy
    from rclpy.duration import Duration

    # Wait until the victim has matched us (discovery), so the probe's duration is spent being heard.
    deadline = time.monotonic() + 10.0
    while publisher.get_subscription_count() == 0 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    sent = 0
    end = time.monotonic() + seconds
    next_time = time.monotonic()
    while time.monotonic() < end:
        publisher.publish(make_message())
        sent += 1
        next_time += 1.0 / rate
        time.sleep(max(0.0, next_time - time.monotonic()))
    # Our writer matching the victim's reader does not mean the reader has matched us: discovery runs each way on
    # its own, and a victim whose discovery thread is busy (opening our shared-memory port took a third of a second,
    # docs/RESULTS.md, "Start-up stall") matches later. A probe that left before then was never heard at all (seen
    # in CI: no line in the replica's log). Stay until the reader has acknowledged what we sent.
    if not publisher.wait_for_all_acked(Duration(seconds=ACK_TIMEOUT_S)):
        print(f"[probe] the reader did not acknowledge every message within {ACK_TIMEOUT_S:g} s", file=sys.stderr)
    return sent


def teleop(node, args) -> int:
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    from fic_teleop_msgs.msg import TeleoperationCommand

    qos = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=20)
    publisher = node.create_publisher(TeleoperationCommand, "/replica/teleop_command", qos)

    def message() -> TeleoperationCommand:
        command = TeleoperationCommand()
        now = node.get_clock().now().nanoseconds * 1e-9
        stamp = 0.0 if args.epoch_zero else now + args.stamp_offset
        command.header.stamp.sec = int(stamp)
        command.header.stamp.nanosec = int((stamp - int(stamp)) * 1e9)
        command.header.frame_id = SPOOF_FRAME
        command.mode = args.mode
        command.haptic_gain = args.haptic_gain
        command.workspace_scale = args.workspace_scale
        command.velocity_gain = args.velocity_gain
        command.desired_offset.x, command.desired_offset.y, command.desired_offset.z = args.offset
        return command

    return _publish_for(node, publisher, message, args.seconds, args.rate)


def joint_states(node, args) -> int:
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    from fic_core.panda_description import ARM_JOINT_NAMES, NOMINAL_CONFIGURATION

    qos = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=50)
    publisher = node.create_publisher(JointState, "/joint_states", qos)
    # The right names, a plausible arm: the nominal configuration with joint 1 turned by --shift, so a replica
    # that believes it pushes the real arm the other way.
    position = list(NOMINAL_CONFIGURATION)
    position[0] += args.shift

    def message() -> JointState:
        state = JointState()
        now = node.get_clock().now().nanoseconds * 1e-9 - args.stamp_back
        state.header.stamp.sec = int(now)
        state.header.stamp.nanosec = int((now - int(now)) * 1e9)
        state.header.frame_id = SPOOF_FRAME
        state.name = list(ARM_JOINT_NAMES)
        state.position = position
        state.velocity = [0.0] * len(position)
        state.effort = [0.0] * len(position)
        return state

    return _publish_for(node, publisher, message, args.seconds, args.rate)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="probe", required=True)
    for name in ("teleop", "joint-states"):
        probe = sub.add_parser(name)
        probe.add_argument("--seconds", type=float, default=1.5)
        probe.add_argument("--rate", type=float, default=100.0 if name == "teleop" else 500.0)
    teleop_parser = sub.choices["teleop"]
    teleop_parser.add_argument("--offset", type=float, nargs=3, default=(10.0, 10.0, 10.0))
    teleop_parser.add_argument("--stamp-offset", type=float, default=0.0, help="stamp = now + this [s]")
    teleop_parser.add_argument("--epoch-zero", action="store_true", help="stamp = 0")
    teleop_parser.add_argument("--mode", type=int, default=0)
    teleop_parser.add_argument("--haptic-gain", type=float, default=0.5)
    teleop_parser.add_argument("--workspace-scale", type=float, default=1.0)
    teleop_parser.add_argument("--velocity-gain", type=float, default=2.0)
    states_parser = sub.choices["joint-states"]
    states_parser.add_argument("--shift", type=float, default=0.3, help="joint 1 offset from the nominal pose [rad]")
    states_parser.add_argument("--stamp-back", type=float, default=0.0, help="stamps this far behind now [s]")
    args = parser.parse_args(argv)

    import rclpy

    rclpy.init()
    node = rclpy.create_node("fault_probe")
    try:
        sent = teleop(node, args) if args.probe == "teleop" else joint_states(node, args)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    print(f"[probe] {args.probe}: {sent} messages sent")
    return 0


if __name__ == "__main__":
    sys.exit(main())
