"""The replica's outgoing messages from fic_core's reports: FicState, LimitStatus, the poses and /diagnostics.

Conversions only (fields copied, a rotation matrix as a quaternion); what the numbers are is fic_core's
(ReplicaCommand, DesiredPose, PassivityObserver, the controller's tick counters) and docs/INTERFACES.md's.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pinocchio as pin
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped

from fic_core.loop_health import HOLDING, RESUMING, LoopHealth
from fic_core.replica import ReplicaCommand
from fic_core.replica_loop import ReplicaLoop
from fic_teleop_msgs.msg import FicState, LimitStatus
from fic_teleop_runtime.geometry import set_pose
from fic_teleop_runtime.stamps import time_message

#: The /diagnostics status name of the replica's own loop (fic_core.loop_health), read by the launcher and reports.
LOOP_HEALTH_STATUS = "replica loop health"


def fic_state(command: ReplicaCommand, loop: ReplicaLoop, stamp: Time, frame_id: str) -> FicState:
    """FicState is stamped when it is published (``stamp``, the node clock); the pipeline latency (master sample
    -> the command that first used it) is master_age, taken at that first use."""
    desired, passivity = loop.desired, loop.passivity
    state = FicState(controller=command.controller_name, phase=[int(x) for x in command.phase],
                     error=np.concatenate((command.tracking_error, command.rotation_error)).tolist(),
                     latched_max_error=command.latched_max_error.tolist(), force=command.wrench.tolist(),
                     stored_energy=command.stored_energy.tolist(), total_energy=float(command.total_energy),
                     master_age=desired.master_first_use_age, master_stale=desired.master_stale,
                     master_stamp=time_message(desired.master_stamp_used_ns or 0),   # 0: none used yet
                     port_work=passivity.port_work.tolist(), passivity_margin=passivity.margin.tolist(),
                     passivity_margin_min=passivity.min_margin,
                     passivity_violation_ticks=passivity.violation_ticks)
    state.header.stamp, state.header.frame_id = stamp, frame_id
    return state


def limit_status(command: ReplicaCommand, loop: ReplicaLoop, stamp: Time, frame_id: str) -> LimitStatus:
    """LimitStatus with the joint state's stamp; its flags are OR-ed over the ticks since the last one."""
    shaping, violations = loop.take_limit_flags()
    controller = loop.controller
    status = LimitStatus(shaping=shaping, violations=violations, torque_change=float(command.torque_change),
                         torque_ratio=command.torque_ratio.tolist(),
                         torque_rate_ratio=command.torque_rate_ratio.tolist(),
                         joint_velocity_ratio=command.joint_velocity_ratio.tolist(),
                         joint_position_margin=command.joint_position_margin.tolist(),
                         tcp_speed=float(command.tcp_speed), ticks=controller.ticks,
                         shaped_ticks=controller.shaped_ticks, violation_ticks=controller.violation_ticks)
    status.header.stamp, status.header.frame_id = stamp, frame_id
    return status


def pose(stamp: Time, frame_id: str, position: np.ndarray, rotation: np.ndarray) -> PoseStamped:
    message = PoseStamped()
    message.header.stamp, message.header.frame_id = stamp, frame_id
    set_pose(message.pose, position, pin.Quaternion(rotation).coeffs())  # (x, y, z, w)
    return message


def diagnostic_status(loop: ReplicaLoop, safe_hold: str | None, values: Mapping[str, str]) -> DiagnosticStatus:
    """ERROR in the safe hold (``safe_hold``: its reason), WARN while the master is stale or once limits or
    passivity were broken, else OK."""
    status = DiagnosticStatus(name="replica", hardware_id="fic_teleop_replica")
    stale = loop.desired.master_stale
    limits_broken, passivity_broken = loop.controller.violation_ticks, loop.passivity.violation_ticks
    if safe_hold is not None:
        status.level, status.message = DiagnosticStatus.ERROR, f"safe hold: {safe_hold}"
    elif stale or limits_broken or passivity_broken:
        status.level = DiagnosticStatus.WARN
        status.message = ("master stale: holding x_d'" if stale else "limit violations seen" if limits_broken else
                          "passivity violated: the controller gave out energy it did not take in")
    else:
        status.level = DiagnosticStatus.OK
        status.message = "running" if loop.desired.started else "waiting for /joint_states"
    status.values = [KeyValue(key=key, value=value) for key, value in values.items()]
    return status


def loop_health_status(health: LoopHealth) -> DiagnosticStatus:
    """The "replica loop health" status (fic_core.loop_health; docs/SECURITY.md): ERROR while the loop holds, WARN
    while the law is blended back in or once it held, else OK; its keys state_age_ms, tick_gap_ms, holds,
    held_ticks and the rest of LoopHealth.diagnostic_values."""
    status = DiagnosticStatus(name=LOOP_HEALTH_STATUS, hardware_id="fic_teleop_replica")
    if health.state == HOLDING:
        status.level, status.message = DiagnosticStatus.ERROR, f"holding: {health.reason}"
    elif health.state == RESUMING or health.holds:
        status.level = DiagnosticStatus.WARN
        status.message = ("resuming: the law blended in from the hold" if health.state == RESUMING else
                          f"held {health.holds} times: {health.reason}")
    else:
        status.level, status.message = DiagnosticStatus.OK, "state ages and tick gaps within their bounds"
    status.values = [KeyValue(key=key, value=value) for key, value in health.diagnostic_values().items()]
    return status
