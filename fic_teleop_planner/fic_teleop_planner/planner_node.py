"""Planner node: the autonomous part x_d'' of the replica's command (paper Eqs. 5-6, docs/CONTROL_LAWS.md).

Wiring around fic_core.planner_station.PlannerStation (the runner steps the same object): its timer calls
``step(now)`` and publishes what it returns. A trajectory source (fic_core.trajectories: the paper's circle, a fixed
point or via-points, chosen by the ``trajectory`` parameter) gives the next trajectory point x_t(t);
fic_core.HarmonicPlanner turns it into x_d'', published as /planner/desired_pose (PoseStamped, panda_link0) at
``publish_rate``, with the planner's acceleration on /planner/desired_accel (AccelStamped, same stamp) so that the
replica can feed the superimposed motion's inertia forward (an addition beyond the paper, see fic_core.replica). The
replica superimposes it on the operator's offset: x_d = x_d' + x_d''. x_d'' is an absolute position in the robot base
frame; the planner starts at ``start_position`` (empty: the trajectory's first point) and the trajectory's clock starts
``start_delay`` seconds after the node. The orientation is a fixed parameter (the planner plans positions).

Runtime changes (validated, refused with a reason): a new trajectory or trajectory parameter restarts the
trajectory's clock and the planner moves harmonically from where it is; a new natural_frequency or max_velocity
restarts the planner at its current position, at rest.
"""
from __future__ import annotations

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import AccelStamped, PoseStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

# Submodule imports: from the repository root a bare `import fic_core` finds the project folder fic_core/ as a
# namespace package first (the editable install resolves submodules only).
from fic_core.errors import FicInputError
from fic_core.planner_station import (
    HARMONIC_PLANNER_PARAMETERS,
    PLANNER_PARAMETERS,
    READ_ONLY,
    TRAJECTORIES,
    TRAJECTORY_PARAMETERS,
    PlannerParameters,
    PlannerStation,
    make_source,
)
from fic_teleop_runtime import qos
from fic_teleop_runtime.geometry import set_pose, set_xyz
from fic_teleop_runtime.node_main import NodeEntry, run_entry
from fic_teleop_runtime.parameters import Schema, declare
from fic_teleop_runtime.periodic import PeriodicCallbacks

# docs/CONVENTIONS.md: RELIABLE, the streams' deep writer history (a stalled reader, the recorder, loses nothing)
POSE_QOS, DIAGNOSTICS_QOS = qos.STREAM_WRITER, qos.DIAGNOSTICS
#: The station's tables, kept importable from here (what the node declares and refuses at run time).
__all__ = ["HARMONIC_PLANNER_PARAMETERS", "PLANNER_PARAMETERS", "READ_ONLY", "SCHEMA", "TRAJECTORIES",
           "TRAJECTORY_PARAMETERS", "PlannerNode", "make_source"]

#: The planner's table (fic_core.planner_station): the node declares these rows, the station takes their values as
#: one PlannerParameters.
SCHEMA = Schema("planner.yaml", PLANNER_PARAMETERS.values())


class PlannerNode(Node):
    def __init__(self, **node_options) -> None:  # node_options: rclpy Node keywords (node_group.py)
        super().__init__("planner", **node_options)
        self._periodic = PeriodicCallbacks(self)  # timers that follow the simulated clock (periodic.py)
        values = declare(self, SCHEMA)  # every row with its config/planner.yaml value; unknown keys refused
        p = PlannerParameters.from_values(values)
        # Stepped in periods no longer than publish_rate's, whatever the timer does (fic_core.planner_schedule).
        self._station = PlannerStation(p, self._now())
        self._frame_id = p.frame_id

        self._publisher = self.create_publisher(PoseStamped, "/planner/desired_pose", POSE_QOS)
        self._accel_publisher = self.create_publisher(AccelStamped, "/planner/desired_accel", POSE_QOS)
        self._diagnostics_publisher = self.create_publisher(DiagnosticArray, "/diagnostics", DIAGNOSTICS_QOS)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._periodic.create(1.0 / p.publish_rate, self._tick)
        self._periodic.create(1.0 / p.diagnostics_rate, self._publish_diagnostics)
        self.get_logger().info(
            f"planner up: trajectory {p.trajectory}, w_n = {p.natural_frequency} rad/s, "
            f"v_d = {p.max_velocity} m/s, start {np.round(self._station.planner.position, 4).tolist()}")

    # -- parameters -----------------------------------------------------------------------------------------
    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        try:
            notices = self._station.configure({p.name: p.value for p in parameters}, self._now())
        except FicInputError as error:
            return SetParametersResult(successful=False, reason=str(error))
        for _, line in notices:
            self.get_logger().info(line)
        return SetParametersResult(successful=True)

    # -- loop -----------------------------------------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _tick(self) -> None:
        set_point = self._station.update(self._now())
        message = PoseStamped()
        message.header.stamp = self.get_clock().now().to_msg()
        message.header.frame_id = self._frame_id
        set_pose(message.pose, set_point.position, set_point.orientation)
        self._publisher.publish(message)
        accel = AccelStamped(header=message.header)
        set_xyz(accel.accel.linear, set_point.acceleration)
        self._accel_publisher.publish(accel)

    def _publish_diagnostics(self) -> None:
        status = DiagnosticStatus(name="planner", hardware_id="planner", level=DiagnosticStatus.OK, message="ok")
        status.values = [KeyValue(key=key, value=text) for key, text in self._station.diagnostic_values().items()]
        array = DiagnosticArray()
        array.header.stamp = self.get_clock().now().to_msg()
        array.status = [status]
        self._diagnostics_publisher.publish(array)


def main(args: list[str] | None = None) -> None:
    run_entry(ENTRY, args)


ENTRY = NodeEntry(PlannerNode, "planner", follow_sim_time=False)  # its timers: periodic.py


if __name__ == "__main__":
    main()
