"""The test's side of the master and planner nodes (test/nodes/test_master_planner_nodes.py,
test_master_operator_tools.py): publishers, received messages, parameter calls."""
from __future__ import annotations

import time

import rclpy
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.experimental import EventsExecutor
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=20)
JOY_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=50)
STARTUP_TIMEOUT = 60.0  # the machine may be shared: importing fic_core (pinocchio) can take seconds


class Peer:
    """The test's side of the graph: publishers, latest received messages, parameter calls."""

    def __init__(self, context, name: str) -> None:
        self.node = rclpy.create_node(name, context=context)
        self.executor = EventsExecutor(context=context)
        self.executor.add_node(self.node)
        self.received: dict[str, list] = {}

    def subscribe(self, message_type, topic: str) -> None:
        self.received[topic] = []
        self.node.create_subscription(message_type, topic, self.received[topic].append, QOS)

    def spin_for(self, seconds: float, every: float = 0.0, action=None) -> None:
        deadline = time.monotonic() + seconds
        next_action = time.monotonic()
        while time.monotonic() < deadline:
            if action is not None and time.monotonic() >= next_action:
                action()
                next_action += every
            self.executor.spin_once(timeout_sec=0.005)

    def spin_until(self, condition, timeout: float, every: float = 0.01, action=None) -> bool:
        deadline = time.monotonic() + timeout
        next_action = time.monotonic()
        while time.monotonic() < deadline:
            if action is not None and time.monotonic() >= next_action:
                action()
                next_action += every
            if condition():
                return True
            self.executor.spin_once(timeout_sec=0.005)
        return condition()

    def set_parameter(self, node: str, name: str, value) -> tuple[bool, str]:
        """Set one parameter of ``node`` (its type from the Python value: a float is a double, a bool a bool, a
        list of floats a double array); (successful, reason)."""
        client = self.node.create_client(SetParameters, f"/{node}/set_parameters")
        assert client.wait_for_service(timeout_sec=20.0)
        request = SetParameters.Request(parameters=[Parameter(name, value=value).to_parameter_msg()])
        future = client.call_async(request)
        assert self.spin_until(future.done, 20.0)
        self.node.destroy_client(client)
        result = future.result().results[0]
        return result.successful, result.reason

    def get_parameter(self, node: str, name: str):
        client = self.node.create_client(GetParameters, f"/{node}/get_parameters")
        assert client.wait_for_service(timeout_sec=20.0)
        future = client.call_async(GetParameters.Request(names=[name]))
        assert self.spin_until(future.done, 20.0)
        self.node.destroy_client(client)
        return future.result().values[0]

    def close(self) -> None:
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
