"""The replica loop's parameters as one typed object, and the controller built from it.

``REPLICA_NUMBERS`` and ``REPLICA_SWITCHES``, with the ``controller`` row, are the loop's part of the replica's table
(fic_core.replica_station's REPLICA_PARAMETERS, which the node declares and the in-process runner reads
config/replica.yaml against); ``ReplicaLoopParameters`` is generated from them (fic_core.parameter_row), so a value
out of its row's range or a name no row has is refused where the object is built. The defaults are
config/replica.yaml's alone (one home for each value). ``checked`` adds the rules that tie rows together (the
controller's name, the control rate against the joint states, the paper law's switches);
``build_replica_controller`` makes the ReplicaController (paper Eq. 7 with the FIC, or the linear baseline, a
null-space posture and the postural optimisation) for a set of them.
"""
from __future__ import annotations

import dataclasses

from .baseline import LinearImpedance
from .errors import FicInputError
from .limits import PandaLimits
from .parameter_row import ParameterRow, number, parameter_set, rows_by_name, switch, text
from .pose_attractor import PoseAttractor
from .postural_optimisation import PosturalOptimisation
from .posture import NullSpacePosture
from .profile import ForceProfile
from .replica import ReplicaController
from .robot_model import RobotModel

#: The numbers (config/replica.yaml holds their values).
REPLICA_NUMBERS: dict[str, ParameterRow] = rows_by_name(
    number("translation_stiffness", 1.0, 100000.0, "FIC K0 of translation [N/m] (paper Sec. III: 200)"),
    number("translation_saturation_error", 0.0001, 1.0, "FIC x_b of translation [m] (paper: 0.05)"),
    number("translation_saturation_start", 0.0, 0.99, "FIC xi of translation, in [0, 1)"),
    number("translation_max_force", 0.01, 500.0, "FIC F_max of translation [N], >= xi*K0*x_b"),
    number("rotation_stiffness", 0.1, 10000.0, "FIC K0 of rotation [N m/rad]"),
    number("rotation_saturation_error", 0.001, 3.14, "FIC x_b of rotation [rad]"),
    number("rotation_saturation_start", 0.0, 0.99, "FIC xi of rotation, in [0, 1)"),
    number("rotation_max_force", 0.01, 100.0, "FIC F_max of rotation [N m], >= xi*K0*x_b"),
    number("rate_deadband_translation", 0.0, 1.0, "FIC dead-band on d|e|/dt for entering C, translation [m/s]"),
    number("rate_deadband_rotation", 0.0, 10.0, "FIC dead-band on d|e|/dt for entering C, rotation [rad/s]"),
    number("linear_translation_damping", 0.0, 10000.0, "baseline (controller: linear) damping [N s/m]; K = "
                                                       "translation_stiffness"),
    number("linear_rotation_damping", 0.0, 1000.0, "baseline damping of rotation [N m s/rad]; K = rotation_stiffness"),
    number("posture_stiffness", 0.0, 500.0, "null-space pull toward the nominal configuration [N m/rad]"),
    number("posture_damping", 0.0, 100.0, "null-space joint damping [N m s/rad]"),
    number("posture_limit_band", 0.01, 1.0, "joint-limit repulsion acts within this distance of a URDF limit [rad]"),
    number("posture_limit_stiffness", 0.0, 1000.0, "joint-limit repulsion gain [N m/rad]"),
    number("velocity_horizon", 0.001, 1.0, "horizon of the velocity-limit predictions of the postural optimisation "
                                           "[s]"),
    number("control_rate", 1.0, 1000.0, "control law rate [Hz]; below the joint-state rate the torque is held in "
                                        "between"),
    number("command_period", 0.0001, 0.1, "period of /joint_states and of the published commands [s] (torque slew "
                                          "step)"),
    number("master_timeout", 0.01, 60.0, "teleoperation commands older than this (by receipt) are stale: x_d' is held "
                                         "[s]"),
    number("resume_speed", 0.001, 2.0, "speed at which x_d' moves to the commanded value after a stale period [m/s]"),
    number("set_point_acceleration_filter", 0.0, 1.0, "time constant of the acceleration estimate of x_d' (fed "
                                                      "forward when offset_feedforward is true) [s]"),
    number("offset_feedforward_contact_force", 0.01, 200.0, "with offset_feedforward_contact_gate: after a contact "
                                                            "(the measured |F_R| at or above this) the offset "
                                                            "feedforward waits one round trip of the link plus "
                                                            "offset_feedforward_settle [N] "
                                                            "(fic_core.offset_feedforward_gate)"),
    number("offset_feedforward_settle", 0.0, 10.0, "... the wait beyond the round trip [s]"),
    number("set_point_extrapolation", 0.0, 0.5, "x_d'' moves on along its last velocity for at most this long after "
                                                "a planner sample (first-order hold between samples) [s]; 0: held "
                                                "as steps (x_d' has its own hold over the link's learned interval: "
                                                "interpolate_link_samples)"),
    number("desired_velocity_filter", 0.0, 1.0, "time constant of the x_d velocity estimate fed to the FIC's error "
                                                "rate [s]; 0 disables it (zero desired twist)"),
    number("pose_rate", 1.0, 1000.0, "rate of /replica/desired_pose, /replica/tcp_pose, /replica/feedback_wrench [Hz]"),
    number("status_rate", 1.0, 1000.0, "rate of /replica/fic_state and /replica/limit_status [Hz]; LimitStatus flags "
                                       "are OR-ed over the ticks since the last message and its tick counters are "
                                       "cumulative, so a lower rate loses no count"),
    number("diagnostics_rate", 0.1, 10.0, "rate of /diagnostics [Hz]"),
    # The replica watching its own loop (fic_core.loop_health, docs/SECURITY.md "The replica's own loop").
    number("loop_max_state_age", 0.001, 10.0, "a control tick on a joint state older than this holds the arm instead "
                                              "of applying the law (gravity and joint damping) [s]"),
    number("loop_max_tick_gap", 0.001, 10.0, "control ticks further apart than this hold the arm the same way [s]"),
    number("loop_resume_ticks", 1.0, 100000.0, "healthy control ticks in a row before the law takes over from a hold"),
    number("loop_resume_ramp", 0.0, 10.0, "the law is blended in from the hold over this long after a hold [s]"),
)

#: The on/off parameters.
REPLICA_SWITCHES: dict[str, ParameterRow] = rows_by_name(
    switch("answer_every_state", "publish a command for every joint state (the held torque between control ticks), as "
                                 "the simulator's lockstep mode needs; false: only at control ticks, the robot "
                                 "holding the last command in between (realtime; saves a 1 kHz stream when "
                                 "control_rate is below 1 kHz)"),
    switch("tick_on_command", "also run a control tick at the first joint state after a new teleoperation command, "
                              "instead of waiting for the control_rate grid, which restarts from that tick: the "
                              "command is applied up to one control period sooner, for at most one extra tick per "
                              "command (the launcher sets it with --scheduling fifo; off, the law runs at "
                              "control_rate exactly, as the bandwidth sweep needs)"),
    switch("paper_law", "true: exactly paper Eq. 7 (C qd + G + J^T FIC) with the posture and the postural "
                        "optimisation, nothing else: the planner and offset feedforward and the joint friction "
                        "compensation are off whatever their own parameters say (docs/CONTROL_LAWS.md, 'Terms beyond "
                        "Eq. 7')"),
    switch("planner_feedforward", "feed the planner's acceleration (/planner/desired_accel) forward through the "
                                  "task-space inertia, J^T Lambda a_d (beyond paper Eq. 7: the FIC compensates no "
                                  "inertia)"),
    switch("offset_feedforward", "feed the estimated acceleration of the teleoperated x_d' forward the same way "
                                 "(beyond paper Eq. 7; fic_core.link_hold: from the hold's velocity changes at "
                                 "successive commands, low-pass filtered)"),
    switch("interpolate_link_samples", "x_d' between the link's samples, rebuilt over the sample interval learned "
                                       "from their stamps (fic_core.link_hold): true, a straight line to each new "
                                       "sample (one interval of latency, never beyond a sample); false, the newest "
                                       "sample moved on along the last two samples' slope for one interval (no "
                                       "latency, overshoots a turn). Either way the feedforward of x_d''s "
                                       "acceleration acts over the whole interval, at any link rate"),
    switch("offset_feedforward_contact_gate", "after a contact, no offset feedforward until the contact's echo "
                                              "through the operator has passed (fic_core.offset_feedforward_gate; "
                                              "off by default: it costs free-space tracking after every contact, "
                                              "docs/CONTROL_LAWS.md 'Low-rate links')"),
    switch("joint_damping_compensation", "add D qd, the arm's viscous joint friction, to tau_d as Eq. 7 adds C qd "
                                         "(beyond the paper; fic_core.replica)"),
    switch("use_planner_orientation", "track the orientation of /planner/desired_pose; false holds the TCP "
                                      "orientation found at start (the planner plans positions, paper Eqs. 5-6)"),
)

CONTROLLERS = ("fic", "linear", "linear_bounded")
CONTROLLER_DESCRIPTION = ("task-space law: 'fic' (the paper's Fractal Impedance Controller) or 'linear' (the "
                          "baseline spring-damper with the same stiffness) or 'linear_bounded' (the same, its force "
                          "bounded by the "
                          "FIC's F_max: translation_max_force, rotation_max_force)")


#: Every row ReplicaLoop takes, the law's name first (config/replica.yaml also holds the node's driver and
#: input-authority keys: fic_core.replica_station).
REPLICA_LOOP_ROWS: dict[str, ParameterRow] = {**rows_by_name(text("controller", CONTROLLER_DESCRIPTION)),
                                              **REPLICA_NUMBERS, **REPLICA_SWITCHES}
#: Their names.
REPLICA_LOOP_PARAMETERS = tuple(REPLICA_LOOP_ROWS)
#: The loop's parameters as one typed object, one field a row of REPLICA_LOOP_ROWS (fic_core.parameter_row):
#: ``from_values`` checks each value against its row and refuses a name no row has, naming the nearest.
ReplicaLoopParameters = parameter_set("ReplicaLoopParameters", __name__, "replica", REPLICA_LOOP_ROWS.values(),
                                      "The replica loop's parameters (REPLICA_LOOP_ROWS), one field a row.")


def checked(parameters: ReplicaLoopParameters) -> ReplicaLoopParameters:
    """``parameters`` (each value checked by its row already) under the rules between rows: FicInputError for a
    controller that is not one of CONTROLLERS or a control rate faster than the joint states; with ``paper_law`` the
    terms beyond Eq. 7 switched off."""
    p = parameters
    if p.paper_law:  # Eq. 7 + posture + postural optimisation only
        p = dataclasses.replace(p, planner_feedforward=False, offset_feedforward=False,
                                joint_damping_compensation=False)
    if p.controller not in CONTROLLERS:
        raise FicInputError(f"controller must be one of {CONTROLLERS}, got {p.controller!r}")
    if 1.0 / p.control_rate < p.command_period * 0.999:
        raise FicInputError(f"control_rate {p.control_rate:g} Hz is faster than the joint states "
                            f"(command_period {p.command_period:g} s)")
    return p


def build_replica_controller(robot: RobotModel, limits: PandaLimits,
                             parameters: ReplicaLoopParameters) -> ReplicaController:
    """The ReplicaController for ``parameters`` (``checked`` first; FicInputError names a bad one)."""
    p = checked(parameters)
    if p.controller == "fic":
        controller: PoseAttractor | LinearImpedance = PoseAttractor(
            ForceProfile(p.translation_stiffness, p.translation_saturation_error, p.translation_saturation_start,
                         p.translation_max_force),
            ForceProfile(p.rotation_stiffness, p.rotation_saturation_error, p.rotation_saturation_start,
                         p.rotation_max_force),
            p.rate_deadband_translation, p.rate_deadband_rotation)
    else:
        controller = LinearImpedance(p.translation_stiffness, p.rotation_stiffness, p.linear_translation_damping,
                                     p.linear_rotation_damping,
                                     max_force=(p.translation_max_force, p.rotation_max_force)
                                     if p.controller == "linear_bounded" else None)
    posture = NullSpacePosture(robot.lower_position_limit, robot.upper_position_limit,
                               stiffness=p.posture_stiffness, damping=p.posture_damping,
                               limit_band=p.posture_limit_band, limit_stiffness=p.posture_limit_stiffness)
    period = 1.0 / p.control_rate
    optimisation = PosturalOptimisation(limits, period, velocity_horizon=p.velocity_horizon)
    return ReplicaController(robot, controller, limits=limits, posture=posture, control_period=period,
                             optimisation=optimisation,
                             joint_damping_compensation=p.joint_damping_compensation,
                             # The feedforward never pushes harder than the FIC may (fic_core.replica).
                             feedforward_limit=(p.translation_max_force, p.rotation_max_force),
                             command_period=p.command_period)
