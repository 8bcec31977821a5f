"""The test's side of a replica node (test/nodes/test_replica_node.py, test_replica_loop_health.py,
test_hardware_profiles.py): a robot that publishes joint states and records the answers."""
from __future__ import annotations

import time

from fic_core.panda_description import ARM_JOINT_NAMES, NOMINAL_CONFIGURATION


class Robot:
    """Test side: publishes /joint_states of an arm at rest and records what the replica publishes."""

    def __init__(self, context) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64MultiArray

        from fic_teleop_msgs.msg import FicState, LimitStatus, TeleoperationCommand

        stream = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=50)
        status = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=20)
        # Deep reader histories: a test process that lags must not lose what it checks.
        record = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=5000)
        self.node = Node("test_robot", context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.joint_state_pub = self.node.create_publisher(JointState, "/joint_states", stream)
        self.teleop_pub = self.node.create_publisher(TeleoperationCommand, "/replica/teleop_command", status)
        self.commands: list[list[float]] = []
        self.fic_states: list = []
        self.limit_status: list = []
        self.node.create_subscription(Float64MultiArray, "/effort_controller/commands",
                                      lambda m: self.commands.append(list(m.data)), record)
        self.node.create_subscription(FicState, "/replica/fic_state", self.fic_states.append, record)
        self.node.create_subscription(LimitStatus, "/replica/limit_status", self.limit_status.append, record)
        #: (stamp [ns], the replica's statistics) of each /diagnostics message (the replica is its only writer here)
        self.diagnostics: list[tuple[int, dict[str, str]]] = []
        self.loop_health: dict[str, str] = {}   # the last 'replica loop health' status's values
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, record)
        self.state_stamps: list[int] = []    # [ns] of every joint state published
        self.teleop_stamps: list[int] = []   # [ns] of every teleoperation command published
        self.JointState = JointState
        self.TeleoperationCommand = TeleoperationCommand
        # Shuffled joint order (and an extra finger joint): the replica must reorder by name.
        self.names = [ARM_JOINT_NAMES[i] for i in (3, 0, 6, 1, 5, 2, 4)] + ["panda_finger_joint1"]

    def _on_diagnostics(self, message) -> None:
        for status in message.status:
            if status.name == "replica":
                stamp = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
                self.diagnostics.append((stamp, {value.key: value.value for value in status.values}))
            elif status.name == "replica loop health":
                self.loop_health = {value.key: value.value for value in status.values}

    def spin(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.01)

    def spin_until(self, condition, timeout: float) -> bool:
        """Spin until ``condition()`` holds or ``timeout`` [s] has passed; whether it holds."""
        deadline = time.monotonic() + timeout
        while not condition() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.01)
        return condition()

    def wait_for_replica(self, timeout: float = 30.0) -> None:
        """Until discovery has matched this side's writers and readers with the replica's (a message sent
        before that is lost, which a count asserted afterwards would read as the replica's doing)."""
        topics = ("/effort_controller/commands", "/replica/fic_state", "/replica/limit_status", "/diagnostics")
        assert self.spin_until(lambda: self.joint_state_pub.get_subscription_count() >= 1
                               and self.teleop_pub.get_subscription_count() >= 1
                               and all(self.node.count_publishers(topic) >= 1 for topic in topics), timeout), \
            "the replica's topics were not matched"

    def publish_until(self, condition, timeout: float = 30.0, **joint_states) -> bool:
        """Joint states (``publish_joint_states`` arguments) in 0.1 s slices until ``condition()`` holds or
        ``timeout`` [s] has passed: what the replica answers takes the time the machine's load gives it."""
        deadline = time.monotonic() + timeout
        while not condition() and time.monotonic() < deadline:
            self.publish_joint_states(0.1, **joint_states)
        return condition()

    def replica_ticks_when_quiet(self, since_ns: int, timeout: float = 30.0) -> int:
        """The replica's control-tick count once it has answered every joint state it got: two /diagnostics
        messages stamped after ``since_ns`` (when this side stopped publishing) that report the same count."""
        def quiet() -> bool:
            after = [values["ticks"] for stamp, values in self.diagnostics if stamp > since_ns]
            return len(after) >= 2 and after[-1] == after[-2]
        assert self.spin_until(quiet, timeout), self.diagnostics[-3:]
        return int(self.diagnostics[-1][1]["ticks"])

    def publish_joint_states(self, seconds: float, period: float = 0.004, teleop_offset=None,
                             teleop_period: float = 0.004) -> None:
        """Joint states of the arm at rest at the nominal configuration, every ``period`` (wall clock)."""
        position = {name: value for name, value in zip(ARM_JOINT_NAMES, NOMINAL_CONFIGURATION)}
        position["panda_finger_joint1"] = 0.02
        deadline = time.monotonic() + seconds
        next_teleop = next_state = time.monotonic()
        while time.monotonic() < deadline:
            while time.monotonic() < next_state:  # paced: the replica must not be flooded
                self.executor.spin_once(timeout_sec=max(0.0, next_state - time.monotonic()))
            next_state += period
            message = self.JointState()
            message.header.stamp = self.node.get_clock().now().to_msg()
            self.state_stamps.append(message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec)
            message.name = self.names
            message.position = [position[name] for name in self.names]
            message.velocity = [0.0] * len(self.names)
            self.joint_state_pub.publish(message)
            if teleop_offset is not None and time.monotonic() >= next_teleop:
                self.publish_teleop(teleop_offset)
                next_teleop += teleop_period

    def publish_teleop(self, offset) -> None:
        message = self.TeleoperationCommand()
        message.header.stamp = self.node.get_clock().now().to_msg()
        self.teleop_stamps.append(message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec)
        message.desired_offset.x, message.desired_offset.y, message.desired_offset.z = (float(v) for v in offset)
        message.haptic_gain = 0.5
        message.workspace_scale = 1.0
        self.teleop_pub.publish(message)

    def set_parameter(self, name: str, value) -> tuple[bool, str]:
        from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
        from rcl_interfaces.srv import SetParameters

        client = self.node.create_client(SetParameters, "/replica/set_parameters")
        assert client.wait_for_service(timeout_sec=10.0)
        parameter_value = ParameterValue()
        if isinstance(value, str):
            parameter_value.type, parameter_value.string_value = ParameterType.PARAMETER_STRING, value
        else:
            parameter_value.type, parameter_value.double_value = ParameterType.PARAMETER_DOUBLE, float(value)
        future = client.call_async(SetParameters.Request(parameters=[Parameter(name=name, value=parameter_value)]))
        deadline = time.monotonic() + 10.0
        while not future.done() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.05)
        self.node.destroy_client(client)
        result = future.result().results[0]
        return result.successful, result.reason
