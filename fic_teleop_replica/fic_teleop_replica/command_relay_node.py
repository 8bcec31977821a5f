"""Torque-command relay with a watchdog, between the replica and a real arm's forward command controller.

    replica_node -- /replica/effort_command --> command_relay -- /effort_controller/commands --> franka_ros2

Every replica command is forwarded unchanged at once, with its layout: the label naming the joint state it was
computed on (fic_core.command_stamp) goes on to the robot, which refuses a torque computed on too old a state. When none
has come for ``timeout`` (the replica died, hung or lost its host), the relay ramps the command to the rest command over
``ramp_time`` and holds it (fic_core.command_watchdog: zero when the arm compensates its own gravity, G(q) at the last
joint state otherwise); the replica's next command is forwarded again. Each transition is one log line. The simulated
robot has this watchdog built in (robot_node's stale-command hold), so the relay is started with the franka_ros2 profile
only (docs/HARDWARE.md, "Watchdogs"): the replica's output is remapped to /replica/effort_command, and the relay is the
one writer of /effort_controller/commands, as the replica's input authority expects of that topic.
"""
from __future__ import annotations

import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayLayout

from fic_core.command_watchdog import CommandWatchdog
from fic_core.errors import FicInputError
from fic_core.parameter_row import parameter_set
from fic_core.robot_model import RobotModel
from fic_core.torque_semantics import TorqueSemantics
from fic_teleop_runtime import qos
from fic_teleop_runtime.node_main import NodeEntry, run_entry
from fic_teleop_runtime.parameters import Schema, declare, number, switch

NODE_NAME = "command_relay"
SCHEMA = Schema(
    "command_relay.yaml",
    number("timeout", 0.002, 10.0, "seconds without a replica command before the ramp to the rest command starts",
           read_only=True),
    number("ramp_time", 0.0, 10.0, "seconds the ramp from the last command to the rest command takes",
           read_only=True),
    number("check_rate", 10.0, 1000.0, "how often the relay checks for silence and sends the ramp [Hz]",
           read_only=True),
    switch("gravity_compensated_by_robot", "the arm compensates its own gravity: the rest command is zero "
           "(else G(q) at the last /joint_states)", read_only=True),
)
#: The relay's parameters as one typed object, one field a row of SCHEMA (fic_core.parameter_row): a name no row
#: has is refused where it is built, naming the nearest.
CommandRelayParameters = parameter_set("CommandRelayParameters", __name__, "command relay", SCHEMA.rows,
                                       "The command relay's parameters (SCHEMA), checked, one field a row.")
#: What ros2_control's forward command controller subscribes with (rclcpp::SystemDefaultsQoS: reliable, keep
#: last 10); the replica's commands come reliable too, and only the newest matters.
COMMAND_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=10)
#: Written with the robot streams' deep writer history, so that a recorder that stalls loses none of the commands.
COMMAND_WRITER_QOS = qos.ROBOT_STREAM
STATE_QOS = QoSProfile(reliability=ReliabilityPolicy.BEST_EFFORT, history=HistoryPolicy.KEEP_LAST, depth=1)


class CommandRelayNode(Node):
    def __init__(self, **node_options) -> None:  # node_options: rclpy Node keywords (node_group.py)
        super().__init__(NODE_NAME, **node_options)
        # Every row with its config/command_relay.yaml value (unknown keys refused), as one typed object.
        p = CommandRelayParameters.from_values(declare(self, SCHEMA))
        semantics = TorqueSemantics(p.gravity_compensated_by_robot)
        self._watchdog = CommandWatchdog(p.timeout, p.ramp_time, semantics)
        # Silence is measured on the steady clock: a sim clock that stops with the replica would hide it.
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._robot = None if semantics.gravity_compensated_by_robot else RobotModel()
        self._gravity: np.ndarray | None = None
        self._out = self.create_publisher(Float64MultiArray, "/effort_controller/commands", COMMAND_WRITER_QOS)
        self.create_subscription(Float64MultiArray, "/replica/effort_command", self._on_command, COMMAND_QOS)
        if self._robot is not None:
            self.create_subscription(JointState, "/joint_states", self._on_joint_state, STATE_QOS)
        self.create_timer(1.0 / p.check_rate, self._check, clock=self._steady)
        rest = "zero (the arm compensates gravity)" if self._robot is None else "G(q) at the last joint state"
        self.get_logger().info(f"command relay up: /replica/effort_command -> /effort_controller/commands; after "
                               f"{p.timeout:g} s of silence, ramp over {p.ramp_time:g} s to {rest}")

    def _now(self) -> float:
        return self._steady.now().nanoseconds * 1e-9

    def _send(self, values: np.ndarray, layout: MultiArrayLayout | None = None) -> None:
        """``layout``: the replica command's own (its state stamp); the ramp's commands carry none (computed on no
        joint state of the replica's)."""
        message = Float64MultiArray(data=values.tolist())
        if layout is not None:
            message.layout = layout
        self._out.publish(message)

    def _on_command(self, message: Float64MultiArray) -> None:
        try:
            command, ended = self._watchdog.replica_command(message.data, self._now())
        except FicInputError as exc:
            self.get_logger().error(f"refusing a replica command: {exc}; the last good one stays",
                                    throttle_duration_sec=2.0)
            return
        if ended:
            self.get_logger().info("replica commands are back: forwarding them again")
        self._send(command, message.layout)

    def _on_joint_state(self, message: JointState) -> None:
        if len(message.position) != self._robot.model.nq:
            return
        try:
            self._robot.update(message.position, [0.0] * self._robot.model.nq)
        except FicInputError:
            return
        self._gravity = self._robot.gravity.copy()

    def _check(self) -> None:
        command, started = self._watchdog.check(self._now(), self._gravity)
        if started:
            self.get_logger().error(f"no replica command for {self._watchdog.ramp.timeout * 1e3:.0f} ms: ramping "
                                    f"the torque command to the rest command over {self._watchdog.ramp.ramp_time:g} s")
        if command is not None:
            self._send(command)


def _stopped(node: CommandRelayNode) -> None:
    import rclpy

    watchdog = node._watchdog
    rclpy.logging.get_logger(NODE_NAME).info(
        f"command relay stopped: {watchdog.forwarded} forwarded, {watchdog.ramp_commands} ramp commands, "
        f"{watchdog.ramp.engagements} silences")


def main(args: list[str] | None = None) -> None:
    run_entry(ENTRY, args)


ENTRY = NodeEntry(CommandRelayNode, NODE_NAME, stopped=_stopped, follow_sim_time=False)


if __name__ == "__main__":
    main()
