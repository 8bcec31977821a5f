"""The hostile-input probes of docs/RESULTS.md, from an outside process, against the real robot simulation and replica.

The robot node (MuJoCo Panda, realtime) and the replica node run as processes; the test process plays the
channel (a legitimate writer of /replica/teleop_command, x_d' = 0) and watches the simulator's ground-truth TCP
(/sim/tcp_pose, which no input of the replica can fake) and /diagnostics. fic_teleop_experiments.tools.fault_probes is
the outside process. Before fic_core.input_authority each of these moved the arm (0.37-0.6 m, docs/RESULTS.md).
"""
from __future__ import annotations

import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from config_values import config_values
from conftest import robot_and_replica

rclpy = pytest.importorskip("rclpy")
pytestmark = pytest.mark.nodes

PROBES = ["-m", "fic_teleop_experiments.tools.fault_probes"]
POSE_RATE_HZ = config_values("robot.yaml")["object_pose_rate_hz"]
RESUME_SPEED = config_values("replica.yaml")["resume_speed"]   # [m/s] a jump of x_d' is given back at this speed
OFFSET_BOX = config_values("replica.yaml")["offset_workspace"]   # [m] x_d' clamped to +-this per axis about the start


class Watcher:
    """Test side: the channel's legitimate x_d' = 0 (optional), the simulator's TCP and the replica's diagnostics."""

    def __init__(self, context, channel: bool) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import PoseStamped
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
        from std_msgs.msg import Float64MultiArray

        from fic_teleop_msgs.msg import FicState, TeleoperationCommand

        qos = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=100)
        self.node = rclpy.create_node("test_channel", context=context)
        self.tcp: list[tuple[float, np.ndarray]] = []
        self.torques: list[list[float]] = []
        self.replica_status: list = []
        self.commands_used = False   # the replica has used a teleoperation command (FicState.master_stamp set)
        self.node.create_subscription(PoseStamped, "/sim/tcp_pose", self._on_tcp, qos)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, qos)
        self.node.create_subscription(FicState, "/replica/fic_state", self._on_fic_state, qos)
        self.node.create_subscription(Float64MultiArray, "/effort_controller/commands",
                                      lambda m: self.torques.append(list(m.data)), qos)
        if channel:
            self._teleop = self.node.create_publisher(TeleoperationCommand, "/replica/teleop_command", qos)
            self._message = TeleoperationCommand
            self.node.create_timer(0.01, self._publish_teleop)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self._running = True
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        from rclpy.executors import ExternalShutdownException

        while self._running:
            try:
                self.executor.spin_once(timeout_sec=0.02)
            except ExternalShutdownException:  # the fixture shut the context down under a failed test
                return

    def stop(self) -> None:
        self._running = False
        self._thread.join(timeout=5.0)
        # Leave the graph at once: a node left to the context's end can linger in DDS discovery and count as a
        # second writer of /replica/teleop_command in the next test.
        self.executor.remove_node(self.node)
        self.node.destroy_node()

    def _publish_teleop(self) -> None:
        message = self._message()
        message.header.stamp = self.node.get_clock().now().to_msg()
        message.haptic_gain, message.workspace_scale, message.velocity_gain = 0.5, 1.0, 2.0
        self._teleop.publish(message)

    def _on_tcp(self, message) -> None:
        p = message.pose.position
        self.tcp.append((time.monotonic(), np.array([p.x, p.y, p.z])))

    def _on_fic_state(self, message) -> None:
        stamp = message.master_stamp
        self.commands_used = self.commands_used or stamp.sec != 0 or stamp.nanosec != 0

    def _on_diagnostics(self, message) -> None:
        self.replica_status += [status for status in message.status if status.name == "replica"]

    def displacement_since(self, start: float) -> float:
        """Largest distance of the TCP from where it was at ``start`` (monotonic clock)."""
        samples = [(t, p) for t, p in list(self.tcp)]
        before = [p for t, p in samples if t <= start]
        reference = before[-1] if before else samples[0][1]
        return max(float(np.linalg.norm(p - reference)) for t, p in samples if t >= start)

    def wait(self, condition, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if condition():
                return True
            time.sleep(0.05)
        return condition()


def _probe(ros_env: dict[str, str], *arguments: str) -> str:
    result = subprocess.run([sys.executable, *PROBES, *arguments], env=ros_env, capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    return result.stdout


def _watch_poses(watcher: Watcher, seconds: float) -> None:
    """Watch the arm for ``seconds`` of its own time: that many seconds of /sim/tcp_pose at the robot's pose rate
    (a loaded machine stretches them in wall time; a fixed sleep would then watch less of the arm)."""
    wanted = len(watcher.tcp) + int(round(seconds * POSE_RATE_HZ))
    assert watcher.wait(lambda: len(watcher.tcp) >= wanted, 60.0 + 10.0 * seconds), \
        f"{len(watcher.tcp)} of {wanted} TCP poses: the robot stopped publishing"


def _probed(ros_env: dict[str, str], watcher: Watcher, settle: float, *arguments: str) -> float:
    """Run one probe, watch the arm ``settle`` seconds more of its time, stop watching; the monotonic time the
    probe started."""
    start = time.monotonic()
    _probe(ros_env, *arguments)
    _watch_poses(watcher, settle)
    watcher.stop()
    return start


def _arm(start_node, ros_env, rclpy_context, channel: bool):
    robot, replica = robot_and_replica(start_node)
    watcher = Watcher(rclpy_context, channel)
    assert replica.wait_for_output("first joint state", timeout=120.0), replica.output()
    # The probe must be the only other writer: wait out any writer of an earlier test still in discovery.
    expected_writers = 1 if channel else 0
    assert watcher.wait(lambda: watcher.node.count_publishers("/replica/teleop_command") == expected_writers, 30.0), \
        f"{watcher.node.count_publishers('/replica/teleop_command')} writers of /replica/teleop_command before the " \
        "probe"
    assert watcher.wait(lambda: len(watcher.tcp) > 50, 60.0), robot.output()
    if channel:
        # The replica's reader must have matched the channel's writer before a probe starts: the graph above is the
        # test's view. On a loaded machine the probe's writer was matched first, so the replica met it as the only
        # writer and took its first command (as it must: one writer is the channel), then refused it 0.3 s later.
        assert watcher.wait(lambda: watcher.commands_used, 60.0), \
            f"the replica used no command of the test's channel\n{replica.output()}"
    _watch_poses(watcher, 1.0)  # the arm settles under the replica's hold of its start pose
    return robot, replica, watcher


def test_a_second_teleop_writer_is_refused_and_the_arm_stays(start_node, ros_env, rclpy_context) -> None:
    robot, replica, watcher = _arm(start_node, ros_env, rclpy_context, channel=True)
    start = _probed(ros_env, watcher, 1.0, "teleop", "--offset", "10", "10", "10", "--seconds", "1.5")
    moved = watcher.displacement_since(start)
    print(f"[probe] the TCP moved {moved * 1000:.1f} mm")
    log = replica.output()
    assert moved < 0.01, f"the TCP moved {moved:.3f} m\n{log}"  # before: 0.6 m at the speed limit
    refusals = log.count("publishers on it, one is the channel's")
    assert 1 <= refusals <= 2, log  # one line (throttled to one per 2 s), not one per message
    refused = max(int(value.value) for status in watcher.replica_status for value in status.values
                  if value.key == "refused_teleop_commands")
    assert refused >= 1  # counted on /diagnostics (under load the replica's depth-1 queue takes a fraction)
    last = [value.value for status in watcher.replica_status for value in status.values if value.key == "last_refusal"]
    assert last[-1] == "2 publishers on it", last[-1]  # why, on /diagnostics too


#: The probes of the only writer, each refused for its own reason (the words its refusal line says).
MALFORMED_PROBES = [
    (("--stamp-offset", "1e6", "--offset", "0.3", "0.3", "0.3"), "in the receiver's future"),
    (("--epoch-zero", "--offset", "0.3", "0.3", "0.3"), "in the past"),
    (("--mode", "7", "--offset", "0.3", "0.3", "0.3"), "mode 7"),
    (("--haptic-gain", "50", "--velocity-gain", "1e6", "--offset", "0.3", "0.3", "0.3"), "K_H 50"),
]
#: The replica says a refused topic at most once per this period (fic_teleop_runtime.notices.THROTTLE_S).
REFUSAL_LINE_PERIOD_S = 2.0


def test_mistimed_or_malformed_commands_of_the_only_writer_are_refused(start_node, ros_env, rclpy_context) -> None:
    """The four probes one after another on one graph: a refusal keeps the last good x_d' and latches nothing, so
    each probe meets the replica as the first did. Each is judged on its own part of the replica's log, started
    once its predecessor's writer has left the graph and the refusal line's throttle period has passed (else its
    line could be throttled away)."""
    robot, replica, watcher = _arm(start_node, ros_env, rclpy_context, channel=False)
    ended = None
    for arguments, words in MALFORMED_PROBES:
        if ended is not None:
            assert watcher.wait(lambda: watcher.node.count_publishers("/replica/teleop_command") == 0, 30.0), \
                f"the probe before {words!r} still writes /replica/teleop_command"
            time.sleep(max(0.0, ended + REFUSAL_LINE_PERIOD_S + 0.1 - time.monotonic()))
        offset = len(replica.output())
        start = time.monotonic()
        _probe(ros_env, "teleop", "--seconds", "1.0", *arguments)
        ended = time.monotonic()
        _watch_poses(watcher, 0.5)
        moved = watcher.displacement_since(start)
        print(f"[probe] {words}: the TCP moved {moved * 1000:.1f} mm")
        log = replica.output()[offset:]
        assert moved < 0.01, f"{words}: the TCP moved {moved:.3f} m\n{log}"  # before: 0.37 m for the stamps
        assert words in log, log
        assert log.count("refusing /replica/teleop_command") == 1, log
    watcher.stop()


def test_a_huge_offset_is_clamped_to_the_workspace_and_approached_at_the_bounded_speed(start_node, ros_env,
                                                                                      rclpy_context) -> None:
    robot, replica, watcher = _arm(start_node, ros_env, rclpy_context, channel=False)
    start = _probed(ros_env, watcher, 1.5, "teleop", "--offset", "1e308", "-1000.0", "0.0", "--seconds", "0.3")
    log = replica.output()
    assert "outside the workspace" in log and "clamped" in log, log
    torques = np.array(watcher.torques[-200:])
    assert np.all(np.isfinite(torques)), "a non-finite torque"
    moved = watcher.displacement_since(start)
    samples = [(t, p) for t, p in watcher.tcp if t >= start]
    watched = samples[-1][0] - start
    print(f"[probe] the TCP moved {moved * 1000:.1f} mm in the {watched:.1f} s watched")
    # The replica had no command before the probe's (the master stale): its first is only clamped, onto the box
    # corner, and DesiredPose gives that jump back at resume_speed, so the arm heads for the corner at that speed for
    # as long as it is watched (the probe stays until its commands are acknowledged, 0-3 s), never toward 1e308.
    assert moved <= RESUME_SPEED * watched + 0.05, f"the TCP moved {moved:.3f} m in {watched:.1f} s"
    assert moved <= np.linalg.norm([OFFSET_BOX, OFFSET_BOX]) + 0.05, f"the TCP left the workspace box: {moved:.3f} m"
    speeds = [np.linalg.norm(b[1] - a[1]) / (b[0] - a[0]) for a, b in zip(samples[::10], samples[10::10])
              if b[0] - a[0] > 0.02]
    print(f"[probe] TCP speed at most {max(speeds):.2f} m/s")
    assert max(speeds) < 1.5, f"TCP at {max(speeds):.2f} m/s"  # before: 1.70 m/s, the Panda's limit


def test_a_second_joint_state_writer_puts_the_replica_into_its_safe_hold(start_node, ros_env, rclpy_context) -> None:
    from diagnostic_msgs.msg import DiagnosticStatus

    robot, replica, watcher = _arm(start_node, ros_env, rclpy_context, channel=True)
    start = _probed(ros_env, watcher, 1.0, "joint-states", "--seconds", "2.0", "--rate", "500", "--shift", "0.3")
    log = replica.output()
    # One hold (a writer named late gets one more line, "now named by discovery", which is not a second hold)
    assert log.count("The replica sends no more torques") == 1, log
    held = [status for status in watcher.replica_status if status.message.startswith("safe hold")]
    assert held and held[-1].level == DiagnosticStatus.ERROR  # on /diagnostics, on /diagnostics (recorded in a bag)
    moved = watcher.displacement_since(start)
    print(f"[probe] the TCP moved {moved * 1000:.1f} mm; {held[-1].message}")
    # before: 0.47 m; with the graph lookup alone, 0.118 m on a loaded machine (its half-second window)
    assert moved < 0.05, f"the TCP moved {moved:.3f} m\n{log}"
