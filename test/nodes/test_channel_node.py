"""The channel node as a real process over DDS (sim_bridge/channel/channel_node.py): delay, loss, blackout, parameters.

The node is started from the source tree (``python -m sim_bridge.channel.channel_node``), the same module the installed
``channel_node`` executable loads, on a domain reserved for the test (test/conftest.py). The test
process publishes stamped poses into the channel and measures, on the way out, what a replica would see.
"""
from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")
from conftest import unclean_exit  # noqa: E402
from geometry_msgs.msg import PoseStamped  # noqa: E402
from rcl_interfaces.srv import SetParameters  # noqa: E402
from rclpy.experimental import EventsExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402

pytestmark = pytest.mark.nodes

# The probe writes and reads with the product streams' writer history (fic_teleop_runtime.qos, 1000): a
# reliable KEEP_LAST history overwrites what a stalled peer has not taken.
QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=1000)
NODE = "channel_test"
IN_TOPIC, OUT_TOPIC = "/test/in", "/test/out"


@pytest.fixture
def graph(tmp_path, ros_env):
    """A private ROS domain: an rclpy context for the test and a launcher for the channel process."""
    domain = ros_env["ROS_DOMAIN_ID"]
    env = dict(os.environ, ROS_DOMAIN_ID=domain, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               ROS_LOG_DIR=str(tmp_path / "ros_log"), PYTHONUNBUFFERED="1", RCUTILS_COLORIZED_OUTPUT="0")
    saved = {key: os.environ.get(key) for key in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOG_DIR")}
    os.environ.update({key: env[key] for key in saved})
    context = rclpy.Context()
    rclpy.init(context=context)
    processes = []

    def start_channel(**parameters) -> subprocess.Popen:
        command = [sys.executable, "-m", "sim_bridge.channel.channel_node", "--ros-args", "-r", f"__node:={NODE}",
                   "-p", f"routes:=['{IN_TOPIC}:{OUT_TOPIC}:geometry_msgs/msg/PoseStamped']"]
        for key, value in parameters.items():
            command += ["-p", f"{key}:={value}"]
        log = open(tmp_path / f"channel-{len(processes)}.log", "wb")
        process = subprocess.Popen(command, env=env, stdout=log, stderr=subprocess.STDOUT, cwd=tmp_path)
        processes.append((process, log))
        return process

    yield context, start_channel, tmp_path
    problems = []
    for process, log in processes:
        if process.poll() is None:
            process.send_signal(signal.SIGINT)
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        log.close()
        problem = unclean_exit(process.returncode, Path(log.name).read_text(errors="replace"))
        if problem:
            problems.append(f"{Path(log.name).name}: {problem}")
    rclpy.shutdown(context=context)
    for key, value in saved.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value
    if problems:  # every channel stops clean: exit 0, no traceback, no FATAL line (test/conftest.py)
        pytest.fail("a channel node did not stop clean: " + "; ".join(problems), pytrace=False)


class Probe:
    """Publishes stamped poses into the channel at a fixed rate and records what comes out."""

    def __init__(self, context, rate_hz: float) -> None:
        self.node = rclpy.create_node("channel_probe", context=context)
        self.executor = EventsExecutor(context=context)
        self.executor.add_node(self.node)
        self.publisher = self.node.create_publisher(PoseStamped, IN_TOPIC, QOS)
        self.received: list[tuple[float, float, int]] = []     # (receipt time, stamp, sequence)
        self.node.create_subscription(PoseStamped, OUT_TOPIC, self._on_output, QOS)
        self.sent: list[tuple[float, int]] = []
        self.sending = False
        self.node.create_timer(1.0 / rate_hz, self._send)
        self.deliveries: list[tuple[float, str, float]] = []    # (stamp, topic, held) from /channel/deliveries
        from fic_teleop_msgs.msg import ChannelDelivery
        self.node.create_subscription(ChannelDelivery, "/channel/deliveries", lambda m: self.deliveries.append(
            (m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, m.topic, m.held)), QOS)

    def now(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    def _send(self) -> None:
        if not self.sending:
            return
        message = PoseStamped()
        message.header.stamp = self.node.get_clock().now().to_msg()
        message.header.frame_id = "haptic_base"
        message.pose.position.x = float(len(self.sent))           # a sequence number rides in the payload
        self.publisher.publish(message)
        self.sent.append((message.header.stamp.sec + message.header.stamp.nanosec * 1e-9, len(self.sent)))

    def _on_output(self, message: PoseStamped) -> None:
        stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
        self.received.append((self.now(), stamp, int(message.pose.position.x)))

    def spin_for(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.01)

    def spin_until(self, condition, timeout: float) -> bool:
        """Spin until ``condition()`` holds (a count, not a time: a loaded machine slows the probe's timer)."""
        deadline = time.monotonic() + timeout
        while not condition() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.01)
        return condition()

    def wait_connected(self, channel: subprocess.Popen, timeout: float = 30.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            assert channel.poll() is None, "the channel node exited"
            if self.publisher.get_subscription_count() > 0 and self.node.count_publishers(OUT_TOPIC) > 0:
                self.spin_for(0.5)            # let both directions finish matching
                return
            self.spin_for(0.1)
        raise AssertionError("the channel node did not connect")

    def set_parameters(self, *parameters: Parameter):
        client = self.node.create_client(SetParameters, f"/{NODE}/set_parameters")
        assert client.wait_for_service(timeout_sec=10.0)
        future = client.call_async(SetParameters.Request(parameters=[p.to_parameter_msg() for p in parameters]))
        deadline = time.monotonic() + 10.0
        while not future.done() and time.monotonic() < deadline:
            self.spin_for(0.05)
        assert future.done()
        return future.result().results

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()


def test_delay_is_never_early_and_about_200ms_stamps_are_kept_and_a_negative_delay_is_refused(graph):
    context, start_channel, tmp_path = graph
    channel = start_channel(delay=0.2, seed=1)
    # The graph's command rate: the channel's 20-deep reader then rides out a 200 ms stall of the channel node
    # (at 250 Hz a loaded suite run lost 12 of 705 samples in 80 ms; qos.py says why the depth stays 20).
    probe = Probe(context, rate_hz=100.0)
    try:
        probe.wait_connected(channel)
        probe.sending = True
        probe.spin_for(6.0)
        probe.sending = False
        # The last 200 ms of messages are still in the channel: wait for them (a loaded machine takes longer than
        # the delay to hand them over; the assertions below say whether any was lost).
        deadline = time.monotonic() + 5.0
        probe.spin_for(0.5)
        while len(probe.received) < len(probe.sent) and time.monotonic() < deadline:
            probe.spin_for(0.1)
        assert len(probe.sent) > 500
        sent = dict((sequence, stamp) for stamp, sequence in probe.sent)
        # Every message arrives, once, in order, with its stamp untouched.
        sequences = [sequence for _, _, sequence in probe.received]
        assert sequences == sorted(set(sequences)) and len(sequences) == len(sent)
        assert all(stamp == pytest.approx(sent[sequence], abs=1e-9) for _, stamp, sequence in probe.received)
        ages = np.array([receipt - stamp for receipt, stamp, _ in probe.received])
        median, p99 = float(np.median(ages)), float(np.percentile(ages, 99))
        print(f"\nchannel delay through DDS at 100 Hz, set 200 ms: p50 {median * 1e3:.2f} ms, "
              f"p99 {p99 * 1e3:.2f} ms, min {ages.min() * 1e3:.2f} ms")
        # Load can only make a delivery late, never early: the lower bound is strict. That the delay is the one set
        # and not another is read from the earliest delivery, which a loaded machine does not move: of ~600 some
        # come out at the first delivery tick after they are due (one 4 ms period; measured min 200.9 ms, p50
        # 201.6 ms on a quiet machine, 2026-12-02 17:22; the median moves later under load, the minimum hardly).
        assert ages.min() >= 0.2 - 1e-3                  # never early
        assert ages.min() < 0.2 + 0.02
        # One ChannelDelivery per message, carrying the message's own stamp (read from its CDR bytes).
        assert sorted(stamp for stamp, _, _ in probe.deliveries) == pytest.approx(sorted(sent.values()), abs=1e-9)
        assert {topic for _, topic, _ in probe.deliveries} == {OUT_TOPIC}
        held = np.array([held for _, _, held in probe.deliveries])
        assert held.min() >= 0.2 - 1e-3 and held.min() < 0.2 + 0.02  # the channel's own hold, as above

        results = probe.set_parameters(Parameter("delay", Parameter.Type.DOUBLE, -0.1))
        assert not results[0].successful and "delay" in results[0].reason
        results = probe.set_parameters(Parameter("delay", Parameter.Type.DOUBLE, 0.05))
        assert results[0].successful
        results = probe.set_parameters(Parameter("blackout_windows", Parameter.Type.DOUBLE_ARRAY, [2.0, 1.0]))
        assert not results[0].successful and "blackout_windows" in results[0].reason
        # The new delay is in force: a fresh burst comes through in about 50 ms.
        probe.received.clear()
        burst_start = probe.now()
        probe.sending = True
        probe.spin_for(1.0)
        probe.sending = False
        deadline = time.monotonic() + 5.0  # the last 50 ms still in the channel: poll until every one is through
        while len(probe.received) < len([1 for stamp, _ in probe.sent if stamp >= burst_start]) and \
                time.monotonic() < deadline:
            probe.spin_for(0.05)
        ages = np.array([receipt - stamp for receipt, stamp, _ in probe.received[50:]])
        assert ages.min() >= 0.05 - 1e-3 and ages.min() < 0.05 + 0.02  # never early; 50 ms, not 200
    finally:
        probe.close()
    channel.send_signal(signal.SIGINT)
    assert channel.wait(timeout=10) == 0
    log = next(tmp_path.glob("channel-*.log")).read_text()
    assert "channel stopped" in log and "Traceback" not in log


def test_a_logged_delivery_that_is_not_a_route_is_refused_at_start(tmp_path, ros_env):
    """logged_deliveries names the out topics whose deliveries go on /channel/deliveries; a topic no route writes
    (a typo) is refused in one line, exit 2, before anything is forwarded."""
    env = dict(ros_env)
    result = subprocess.run([sys.executable, "-m", "sim_bridge.channel.channel_node", "--ros-args", "-r",
                             f"__node:={NODE}", "-p",
                             f"routes:=['{IN_TOPIC}:{OUT_TOPIC}:geometry_msgs/msg/PoseStamped']",
                             "-p", "logged_deliveries:=['/test/oot']"], env=env, cwd=tmp_path, capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 2
    assert ("cannot start: logged_deliveries names /test/oot, not an out topic of this node's routes (/test/out)"
            in result.stdout + result.stderr)


def test_drop_rate_matches_the_probability(graph):
    context, start_channel, _ = graph
    probability = 0.3
    channel = start_channel(delay=0.01, drop_probability=probability, seed=5)
    probe = Probe(context, rate_hz=500.0)
    try:
        probe.wait_connected(channel)
        probe.sending = True
        # 1,200 samples (3 s at 500 Hz on a quiet machine; under load the timer fell to 982 in 3 s): the binomial
        # test below wants its sample, not a duration.
        assert probe.spin_until(lambda: len(probe.sent) >= 1200, 60.0), f"{len(probe.sent)} sent in 60 s"
        probe.sending = False
        probe.spin_for(0.5)
    finally:
        probe.close()
    n = len(probe.sent)
    lost = n - len(probe.received)
    sigma = math.sqrt(n * probability * (1.0 - probability))
    print(f"\nchannel drop: {lost}/{n} = {lost / n:.3f} (p = {probability})")
    assert abs(lost - n * probability) < 5.0 * sigma     # binomial, 5 sigma


def test_a_blackout_delivers_nothing_and_the_link_comes_back(graph):
    context, start_channel, _ = graph
    channel = start_channel(delay=0.05, time_reference="clock")
    probe = Probe(context, rate_hz=250.0)
    try:
        probe.wait_connected(channel)
        probe.sending = True
        probe.spin_for(0.5)
        start = probe.now() + 0.5
        window = (start, start + 1.0)
        results = probe.set_parameters(Parameter("blackout_windows", Parameter.Type.DOUBLE_ARRAY, list(window)))
        assert results[0].successful, results[0].reason
        probe.spin_for(2.5)
        probe.sending = False
        probe.spin_for(0.3)
    finally:
        probe.close()
    receipts = np.array([receipt for receipt, _, _ in probe.received])
    # A message released just before the window may still be in DDS at its start: 10 ms of slack.
    inside = receipts[(receipts > window[0] + 0.01) & (receipts < window[1])]
    assert inside.size == 0
    assert np.sum(receipts < window[0]) > 100 and np.sum(receipts > window[1] + 0.1) > 100
    stamps = np.array([stamp for _, stamp, _ in probe.received])
    # Lost: everything sent in the window, and what was sent in the 50 ms before it (it would have arrived in it).
    assert not np.any((stamps > window[0] - 0.05 + 0.005) & (stamps < window[1] - 0.005))


def test_in_lockstep_the_heartbeat_follows_the_simulated_clock_and_is_off_by_default(graph):
    """lockstep_heartbeat: after each delivery tick the node publishes its clock on ~/heartbeat, which the robot's
    peer barrier waits for (a channel that lags holds the simulation, not the commands); off, no such publisher."""
    from rosgraph_msgs.msg import Clock
    from std_msgs.msg import Header

    from fic_teleop_runtime.stamps import seconds, time_message

    context, start_channel, _ = graph
    quiet = start_channel(use_sim_time="true")
    probe = Probe(context, rate_hz=100.0)
    clock = probe.node.create_publisher(Clock, "/clock", QoSProfile(depth=10))
    heartbeats: list[float] = []
    probe.node.create_subscription(Header, f"/{NODE}/heartbeat", lambda m: heartbeats.append(
        seconds(m.stamp)), QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT))
    try:
        probe.wait_connected(quiet)
        assert probe.node.count_publishers(f"/{NODE}/heartbeat") == 0
        quiet.send_signal(signal.SIGINT)
        quiet.wait(timeout=10)
        channel = start_channel(use_sim_time="true", lockstep_heartbeat="true")
        deadline = time.monotonic() + 30.0
        while probe.node.count_publishers(f"/{NODE}/heartbeat") == 0 and time.monotonic() < deadline:
            probe.spin_for(0.1)
        assert channel.poll() is None and probe.node.count_publishers(f"/{NODE}/heartbeat") == 1
        probe.spin_for(0.5)
        simulated = 0.0
        for _ in range(500):   # 1 s of simulated time in 2 ms steps, faster than real time
            simulated += 0.002
            nanoseconds = int(round(simulated * 1e9))
            clock.publish(Clock(clock=time_message(nanoseconds)))
            probe.spin_for(0.001)
        probe.spin_for(0.5)
    finally:
        probe.close()
    assert len(heartbeats) > 100, len(heartbeats)
    assert all(b > a for a, b in zip(heartbeats, heartbeats[1:])), "heartbeat stamps go back"
    assert 0.0 <= heartbeats[0] and heartbeats[-1] <= simulated + 1e-9
    assert heartbeats[-1] >= simulated - 0.01    # the delivery tick is 4 ms: the last one is at most one behind

