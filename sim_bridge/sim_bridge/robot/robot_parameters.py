"""The simulated robot's parameters: the table robot_node declares (its SCHEMA, with config/robot.yaml's values) and
the typed object generated from it, which the node and the in-process runner build the robot's station from
(``RobotStation.from_parameters``). Importable without rclpy, as the runner is."""
from __future__ import annotations

from fic_core.parameter_row import (
    ParameterRow,
    integer,
    number,
    numbers,
    parameter_set,
    rows_by_name,
    switch,
    text,
    texts,
)
from fic_core.record_batch_rows import RECORD_BATCH_ROWS
from sim_bridge.robot.scenes import SCENE_NAMES

SUBSCRIBER_WAIT_S = 60.0  # lockstep: longest wall-clock wait for the /joint_states readers before the first step

ROBOT_PARAMETERS: dict[str, ParameterRow] = rows_by_name(
    text("scene", f"scene to build: one of {', '.join(SCENE_NAMES)}"),
    integer("seed", 0, 2 ** 31 - 1, "seed of the scene's random elements (adhesive bond break thresholds)"),
    text("mode", "realtime: wall-clock paced 1 kHz; lockstep: step on each command"),
    number("lockstep_timeout", 0.001, 10.0, "lockstep: longest wall-clock wait for the command of a step before "
                                            "stepping on the last one (counted) [s]"),
    texts("lockstep_peers", "lockstep: header-stamped topics of nodes that follow /clock (device, master, planner); "
                            "no step past t until each has published a stamp >= t - lockstep_peer_lag, and no first "
                            "step "
                            "before each has a publisher (empty: none)"),
    integer("lockstep_subscribers", 0, 100, "lockstep: the simulation starts once /joint_states has this many "
                                            "readers (the replica, a recorder), or after "
                                            f"{SUBSCRIBER_WAIT_S:g} s with a warning"),
    number("lockstep_peer_lag", 0.0, 10.0, "lockstep: how far a peer's newest stamp may trail the simulation (at "
                                           "least its own period) [s]"),
    number("lockstep_peer_timeout", 0.001, 60.0, "lockstep: a peer that holds a step longer than this (wall) is "
                                                 "declared stalled and not waited for until it catches up [s]"),
    number("command_timeout", 0.002, 10.0, "watchdog: commands older than this are replaced by the hold torque "
                                           "(wall s in realtime, simulated s in lockstep) [s]"),
    number("command_state_timeout", 0.001, 10.0, "realtime: a torque command computed on a joint state older than "
                                                 "this (the state stamp it carries, fic_core.command_stamp) is "
                                                 "refused: never applied, the watchdog not released [s]"),
    number("realtime_clock_rate_hz", 0.0, 1000.0, "realtime: /clock publication rate (lockstep: "
                                                  "lockstep_clock_rate_hz) [Hz]"),
    number("lockstep_clock_rate_hz", 1.0, 1000.0, "lockstep: /clock publication rate, a divisor of 1000 (every "
                                                  "follower's periods must be whole multiples of its period) [Hz]"),
    text("step_clock_topic", "lockstep: the simulation's time also on this topic (rosgraph_msgs/Clock) at every "
                             "step, before /clock and the joint state, for the node that answers every state (its "
                             "/clock remapped here); empty: none"),
    number("joint_state_rate_hz", 1.0, 1000.0, "realtime: /joint_states publication rate, a divisor of 1000 "
                                               "(lockstep publishes every step, the replica answers each) [Hz]"),
    number("wrench_rate_hz", 1.0, 1000.0, "/ft_sensor/wrench publication rate, a divisor of 1000 (the sample of "
                                          "that step) [Hz]"),
    number("lateness_rate_hz", 0.0, 1000.0, "/sim/step_lateness publication rate [Hz]"),
    number("object_pose_rate_hz", 0.0, 1000.0, "/sim/object_poses and /sim/tcp_pose publication rate [Hz]"),
    number("diagnostics_rate_hz", 0.0, 100.0, "/diagnostics publication rate [Hz]"),
    numbers("initial_configuration", "joint positions at start, panda_joint1..7 [rad]"),
    text("render_video_path", "write the run to this .gif (or .mp4) at the end; empty: no video"),
    text("snapshot_dir", "write PNG key frames of the run here at the end; empty: none"),
    number("video_frame_rate_hz", 0.1, 60.0, "frames per simulated second taped for the video and key frames [Hz]"),
    number("snapshot_interval", 0.01, 3600.0, "simulated time between key frames [s]"),
    switch("viewer", "open the live MuJoCo viewer (needs a display)"),
    switch("gravity_compensation", "the arm compensates its own gravity at every physics step, as a Franka under "
                                   "torque control: commands then mean tau - G(q) (mujoco_panda.build_panda_spec)"),
    text("driver_interface", "topics, QoS, frames and joint names to speak: sim or franka_ros2 (its twin; "
                             "fic_teleop_runtime.driver_topics)"),
    switch("hold_on_stale_commands", "replace stale commands by the hold torque (command_timeout); false: apply "
                                     "the last command until another comes, as ros2_control's forward controller "
                                     "does"),
    switch("controller_in_process", "the replica runs in this process (a node group with robot_in_process): each "
                                    "joint state and wrench goes straight to its control step and its torque straight "
                                    "back (fic_teleop_runtime.in_process_link); no DDS command subscription"),
    switch("velocity_reflex", "stop the arm (hold torque, commands ignored) once a joint moves beyond the arm "
                              "profile's velocity limit, as a Franka arm stops with joint_velocity_violation"),
)
# How /joint_states and /ft_sensor/wrench reach the recorder (fic_teleop_runtime.record_batch).
ROBOT_PARAMETERS.update(RECORD_BATCH_ROWS)
#: The robot's parameters as one typed object, one field a row of ROBOT_PARAMETERS (fic_core.parameter_row): a name
#: no row has is refused where it is built, naming the nearest.
RobotParameters = parameter_set("RobotParameters", __name__, "robot", ROBOT_PARAMETERS.values(),
                                "The simulated robot's parameters (ROBOT_PARAMETERS), checked, one field a row.")
