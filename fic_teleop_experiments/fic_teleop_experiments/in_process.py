"""The teleoperation graph in one process: the same core objects the nodes wrap, stepped on one simulated clock.

    operator's hand + haptic device (device node, 250 Hz; button presses at 50 Hz): a script, or in E1 the
    closed-loop operator watching the camera frames that come back through the channel (30 Hz, backward delay)
      -> fic_core.MasterStation (master node: force 250 Hz, x_d' 100 Hz)
      -> Channel forward (channel node: delay, jitter, drop, blackouts, rate cap, seeded; delivered at 250 Hz)
      -> fic_core.ReplicaStation (replica node, every joint state answered as in lockstep)  <- PlannerStation 100 Hz
      -> PandaSimulation (robot node, 1 kHz; F/T at 250 Hz)  -> F_R at pose_rate -> Channel backward -> master

Parameters come from config/*.yaml with the launcher's overrides for lockstep (control_rate 1000, every joint state
answered, the operator script and the planner's circle on one origin), so a run here and
``scripts/run_teleop.sh --time-mode lockstep`` execute the same laws at the same rates and delays. What differs:
no DDS (a message is taken in at the millisecond it is sent, where a lockstep graph delivers it within a step or
two), and the nodes' timers fire on exact multiples of their periods. Deterministic for a seed (the channel's
draws, the bond thresholds and, when asked for, the operator's and the task's variation and the reactive hand's
figures are the random elements, each from its own stream of the seed).
"""
from __future__ import annotations

import math
import time as wall_clock
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from fic_core.channel_ports import ChannelPorts
from fic_core.master_station import MasterParameters, MasterStation
from fic_core.panda_description import ARM_JOINT_NAMES
from fic_core.planner_station import PlannerParameters, PlannerStation, make_source
from fic_core.replica_station import ReplicaParameters, ReplicaStation
from fic_core.stopped_trajectory import StoppedTrajectory
from fic_core.trajectories import LapVaryingCircle
from fic_teleop_runtime.workspace import config_folder
from sim_bridge.channel.channel import Channel
from sim_bridge.channel.channel_parameters import ChannelParameters, channel_config
from sim_bridge.device.closed_loop_operator import VIDEO_RATE_HZ, ClosedLoopOperator, ClosedLoopParameters, Frame
from sim_bridge.device.device_parameters import DeviceNodeParameters, haptic_device_parameters
from sim_bridge.device.device_parameters import hand_parameters as device_hand_parameters
from sim_bridge.device.device_station import DeviceStation
from sim_bridge.device.haptic_device import HapticDevice
from sim_bridge.device.operator_scripts import superimposition_script
from sim_bridge.device.reactive_hand import ReactiveHand, ReactiveHandParameters
from sim_bridge.device.shape_sorting_operator import ShapeSortingOperator, ShapeSortingParameters, SortingFrame
from sim_bridge.device.virtual_operator import Hand, ScriptedOperator, load_script
from sim_bridge.robot.mujoco_panda import PandaSimulation
from sim_bridge.robot.robot_parameters import RobotParameters
from sim_bridge.robot.robot_station import RobotStation

STEP = 0.001                     # the robot's physics step and joint-state period [s]
SCRIPT_CIRCLE_START_S = 2.0      # the launcher's origin of the E1 script and the planner's circle
PLANNER_LAG_S = 0.2
JOY_RATE_HZ = 50.0               # the device node's button messages
CAMERA_RATE_HZ = VIDEO_RATE_HZ    # the closed-loop operator's video frames
#: "shape_sorting": E2's closed-loop operator (sim_bridge.device.shape_sorting_operator; docs/EXPERIMENTS.md "E2").
OPERATORS = ("scripted", "closed_loop", "shape_sorting")
HANDS = ("passive", "reactive")
#: A task that does not repeat (RunConfig.task_variation; docs/EXPERIMENTS.md "Claims"): per seed, the circle's laps
#: (LapVaryingCircle.randomised) and the closed-loop operator's moves (closed_loop_operator's VARYING) from these
#: uniform ranges. The diameters keep both obstacles on the path (their 0.06 m width about the paper's 0.20 m).
TASK_PERIOD_RANGE_S = (4.5, 5.5)           # each lap's period (the paper's 5 s +-10 %), the speed blended between laps
TASK_DIAMETER_RANGE_M = (0.17, 0.23)       # each lap's end diameter (the paper's 0.20 m +-15 %)
#: The start angle: on the arc at least 50 deg from both obstacles (at 90 and 270 deg) that meets the pushable one
#: first, so that the robot does not start on an obstacle and the fixed one comes at least 230 deg (2.6 s) into the
#: circle, when an operator at a short delay has seen the robot move (from the other arc, at 0.7-1.8 s, nobody could).
TASK_PHASE_RANGES_RAD = ((math.radians(140.0), math.radians(220.0)),)
MOVE_AMPLITUDE_RANGE = (0.85, 1.1)         # each avoid/push move's size, times the script's
MOVE_DURATION_RANGE = (1.0, 1.3)           # each move's hold and ramp times, times the script's (never shorter)
MOVE_TIMING_SPREAD_S = 0.1                 # each move's timing, +- about the predicted passing
WANDER_AMPLITUDE_RANGE_M = (0.005, 0.02)   # the hand's random excursions
WANDER_PERIOD_RANGE_S = (1.0, 4.0)
WANDER_MEAN_GAP_S = 3.0
#: The replica side is the node's fic_core.ReplicaStation on config/replica.yaml: its input authority judges every
#: delivered command here as in the node (the workspace clamp of x_d', its speed bound, forgotten at a resume), its
#: stream guard sees every joint state's stamp, its driver makes the command and F_R. Its one-writer checks have one
#: writer to see in one process. The exchanged-energy observer (an observer only, about 30 us a tick) is left off.


def _parameters(name: str) -> dict[str, Any]:
    data = yaml.safe_load((config_folder() / name).read_text())
    return dict(next(iter(data.values()))["ros__parameters"])


@dataclass(frozen=True)
class ReplicaStall:
    """A replica process starved of CPU from ``start`` to ``end`` [s]: it wakes only after a gap drawn from the
    seed in [min_gap, max_gap], takes the newest joint state (its depth-1 subscription), and its torque reaches the
    robot ``delay`` later, drawn in [min_delay, max_delay] (a tick preempted half-way, the message queued behind
    other work). The robot applies the last command it received until robot.yaml's command_timeout, then its hold
    torque (robot_node's stale-command watchdog).

    ``min_state_age``/``max_state_age``: the state the replica wakes to is older than the newest, by a draw in that
    range (a state that waited in the reader's queue while the process slept; the two-station runaway's were
    22-178 ms old): the loop gets that state with its own stamp, and its age against its clock."""

    start: float
    end: float
    min_gap: float
    max_gap: float
    min_delay: float = 0.0
    max_delay: float = 0.0
    min_state_age: float = 0.0
    max_state_age: float = 0.0
    stale_velocity: bool = True   # False: the old state's q with the newest qd (tells the law's velocity terms apart)


class StarvedReplica:
    """The replica process of ``stalls`` (ReplicaStall), on its own stream of the seed: when it wakes, which state it
    reads, and when its torque reaches the robot. The draws come in the order the runner asks for them, one wake
    after another: the state's age, then the gap to the next wake, then the torque's delay."""

    def __init__(self, stalls: tuple[ReplicaStall, ...], seed: int) -> None:
        self.stalls = stalls
        self._draws = np.random.default_rng([seed, 104729])
        self._wakes = 0.0
        # Torques on their way (arrival, torque, the time of the state it was computed on, the tick's C qd + G).
        self._in_flight: deque[tuple[float, np.ndarray, float, np.ndarray | None]] = deque()
        oldest_state = max((window.max_state_age for window in stalls), default=0.0)
        self._keeps_states = oldest_state > 0.0
        self._past_states: deque[tuple[float, np.ndarray, np.ndarray]] = deque(
            maxlen=int(round(oldest_state / STEP)) + 1)

    def window(self, now: float) -> ReplicaStall | None:
        """The stall at ``now``, None outside every window."""
        return next((window for window in self.stalls if window.start <= now < window.end), None)

    def arrivals(self, now: float) -> list[tuple[np.ndarray, float, np.ndarray | None]]:
        """The torques that reach the robot by ``now``: (torque, its state's time, its tick's C qd + G)."""
        arrived = []
        while self._in_flight and self._in_flight[0][0] <= now:
            arrived.append(self._in_flight.popleft()[1:])
        return arrived

    def asleep(self, now: float, window: ReplicaStall | None) -> bool:
        """The replica sleeps at ``now``, or its last torque is still on its way: no state is read."""
        return window is not None and now < self._wakes or bool(self._in_flight)

    def state(self, now: float, window: ReplicaStall | None, q: np.ndarray,
              qd: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """The joint state the replica reads at ``now`` (the newest is (now, q, qd)): (its time, q, qd)."""
        if self._keeps_states:
            self._past_states.append((now, q.copy(), qd.copy()))
        if window is None or window.max_state_age <= 0.0:
            return now, q, qd
        back = int(round(float(self._draws.uniform(window.min_state_age, window.max_state_age)) / STEP))
        state_time, q_state, qd_state = self._past_states[max(len(self._past_states) - 1 - back, 0)]
        return (state_time, q_state, qd_state) if window.stale_velocity else (state_time, q_state, qd)

    def answered(self, now: float, window: ReplicaStall, torque: np.ndarray | None, state_time: float,
                 tick_dynamics: np.ndarray | None) -> bool:
        """The replica answered at ``now`` within ``window``: its next wake drawn, and ``torque``, if any, sent
        on its way when the window delays torques. Whether it was (then it is not the robot's yet)."""
        self._wakes = now + float(self._draws.uniform(window.min_gap, window.max_gap))
        if torque is None or window.max_delay <= 0.0:
            return False
        self._in_flight.append((now + float(self._draws.uniform(window.min_delay, window.max_delay)),
                                torque.copy(), state_time, tick_dynamics))
        return True


@dataclass
class RunConfig:
    scene: str = "superimposition"
    duration: float = 10.0
    delay: float = 0.2
    jitter: float = 0.0
    drop: float = 0.0
    blackout_windows: tuple[tuple[float, float], ...] = ()
    rate_cap: float = 0.0
    controller: str = "fic"
    # TDPA around the replica's law: the channel ports' passivity controllers act (fic_core.channel_ports);
    # controller "linear_tdpa" is linear_bounded with this on.
    tdpa: bool = False
    control_rate: float = 1000.0
    # True: the arm compensates its gravity (MuJoCo's gravcomp, the robot node's gravity_compensation) and the
    # runner adds C(q, qd) qd at every physics step in place of the replica's, so control_rate lowers the rate of
    # the Cartesian law alone (J^T FIC + posture), as on a Franka arm (docs/EXPERIMENTS.md "Bandwidth sweeps").
    dynamics_at_physics_rate: bool = False
    trajectory: str | None = None      # None: the circle in E1, a fixed point elsewhere (the launcher's choice)
    seed: int = 1
    script_path: Path | None = None    # None: config/operator_scripts/<scene>.yaml (E1: generated, script_delay)
    # The operator (docs/EXPERIMENTS.md "Operators"): "scripted" plays a script; "closed_loop" (E1 only) times
    # its moves from the delayed video (sim_bridge.device.closed_loop_operator). The E1 script's timing is
    # generated for ``script_delay`` (None: the cell's delay, as an expert who practised at it).
    operator: str = "scripted"
    script_delay: float | None = None
    reaction_time: float = 0.25        # [s] the closed-loop operator's; operator_timing_jitter is added to it
    replica_overrides: dict[str, Any] = field(default_factory=dict)
    master_overrides: dict[str, Any] = field(default_factory=dict)   # master.yaml values replaced
    # Per-seed variation of the operator (docs/EXPERIMENTS.md "Operators"): the script's clock is shifted by a draw in
    # [-operator_timing_jitter, +operator_timing_jitter] s, the hand's stiffness and damping scaled by a draw in
    # [1 - hand_impedance_jitter, 1 + hand_impedance_jitter]; both drawn from the seed, off by default.
    operator_timing_jitter: float = 0.0
    hand_impedance_jitter: float = 0.0
    # A starved replica process (ReplicaStall; docs/EXPERIMENTS.md "A starved replica").
    replica_stalls: tuple[ReplicaStall, ...] = ()
    # The robot's bound on the age of the state a torque was computed on (robot_node's command_state_timeout;
    # None: robot.yaml's; math.inf: no such rule, as before it existed).
    robot_command_state_timeout: float | None = None
    # The robot's velocity reflex (robot_node's velocity_reflex; None: robot.yaml's, on): a joint 10 % past its
    # datasheet speed stops the arm, held, for the rest of the run (sim_bridge.robot.velocity_reflex).
    robot_velocity_reflex: bool | None = None
    # The operator's hand (docs/EXPERIMENTS.md "Claims"): "passive" is virtual_operator.Hand (the optimistic relaxed
    # arm); "reactive" adds a stretch reflex and a voluntary response to the felt force (device.reactive_hand), its
    # latencies and gains drawn from the seed.
    hand: str = "passive"
    # A task that does not repeat (closed-loop operator only): the planner's laps and the operator's moves drawn from
    # the seed (TASK_*, MOVE_*, WANDER_* above).
    task_variation: bool = False
    # The quiet tail (docs/EXPERIMENTS.md, "The run verdict"): from this time [s] to ``duration`` the planner's
    # trajectory stops (StoppedTrajectory: x_d'' comes to rest on its last point) and the operator's target holds
    # still (DeviceStation's quiet_from); the hand keeps holding the handle, passive or reactive, and the link, its
    # delay and rate, the master and the replica keep running. The free response the run verdict judges. None: none.
    quiet_from: float | None = None
    # [s] with a quiet tail: the tail goes on past ``duration`` until it has run this long since the robot's last
    # contact (the fixed obstacle touched, or |F_R| at the run verdict's contact_force or more), at most one tail's
    # length more. A touch in the tail is an input to the loop from its surroundings, and the free response the
    # verdict judges is what follows the last one: a touch 4.9 s into an 11 s tail left too little of the tail to
    # see its decay (docs/EXPERIMENTS.md, "Claims"). A contact that recurs to the end keeps the tail going to its
    # cap. 0: fixed.
    tail_clear: float = 0.0


@dataclass
class RunResult:
    time: np.ndarray                  # the replica's pose stamps [s] (pose_rate)
    desired: np.ndarray               # x_d (n, 3)
    tcp: np.ndarray                   # x_R (n, 3)
    force: np.ndarray                 # F_R at those stamps (n, 3)
    offset: np.ndarray                # x_d' in use at those stamps (n, 3)
    objects: dict[str, tuple[np.ndarray, np.ndarray]]   # the scene's objects (position, quaternion) at the end
    wall_s: float
    simulated_s: float
    limit_violations: int
    shaped_ticks: int
    # For the run verdict (fic_teleop_tools.verdict.run_verdict), at the same stamps:
    master: np.ndarray | None = None               # x_M, the handle position (n, 3) [m]
    planner: np.ndarray | None = None              # the planner's x_d (the commanded motion) (n, 3) [m]
    arm_kinetic_energy: np.ndarray | None = None   # 1/2 qd^T M(q) qd of the arm's joints (n,) [J]
    handle_kinetic_energy: np.ndarray | None = None  # 1/2 m_h |v_M|^2 (n,) [J]
    operator_time_shift: float = 0.0               # [s] the draw of operator_timing_jitter
    hand_scale: float = 1.0                        # the draw of hand_impedance_jitter
    operator_target: np.ndarray | None = None      # the script's handle target at those stamps (n, 3) [m]
    passivity_margin_min_j: float = 0.0            # the task-space port's smallest W - (V - V0) (passivity observer)
    passivity_violation_ticks: int = 0
    # Per stamp (n, 5): the channel's master-side and replica-side observers W [J], the energy the channel generated
    # so far [J] (fic_core.channel_ports), the task-space port's smallest passivity margin [J], |offset drift| [m].
    port_energy: np.ndarray | None = None
    obstacle_contact: np.ndarray | None = None     # the robot touches E1's fixed obstacle at those stamps (n,)
    operator_moves: list[tuple[str, float, float]] = field(default_factory=list)  # closed loop: (move, start, passing)
    draws: dict[str, Any] = field(default_factory=dict)   # the seed's task and hand draws (task_variation, hand)
    # The robot side over every physics step (docs/RESULTS.md "Starvation"): the fastest joint [rad/s], the robot's
    # stale-command watchdog engaging, torques it refused as computed on a state older than its bound, the
    # replica loop's own holds (fic_core.loop_health).
    joint_speed_max: float = 0.0
    robot_watchdog_engagements: int = 0
    stale_torques_refused: int = 0
    replica_holds: int = 0
    # The master's side of the command at those stamps: its mode (n,) (fic_core.teleoperation.TeleoperationMode) and
    # the x_d' it sent last (n, 3) [m]; the run verdict's command in velocity mode (VerdictInput.from_run_result).
    command_mode: np.ndarray | None = None
    sent_offset: np.ndarray | None = None
    # [s] the quiet tail's start (RunConfig.quiet_from), None without one: the run verdict judges stability there.
    quiet_from: float | None = None
    # [s] when the robot's velocity reflex stopped the arm (robot_node's velocity_reflex), None if it never did.
    velocity_reflex_time: float | None = None

    @property
    def tracking_error(self) -> np.ndarray:
        return np.linalg.norm(self.desired - self.tcp, axis=1)

    @property
    def speed(self) -> float:
        """Simulated seconds per wall second."""
        return self.simulated_s / self.wall_s


def _every(rate: float) -> int:
    return max(1, int(round(1.0 / (rate * STEP))))


def run(config: RunConfig) -> RunResult:
    """One run of the graph (module docstring)."""
    r, m, pl = _parameters("replica.yaml"), _parameters("master.yaml"), _parameters("planner.yaml")
    trajectory = config.trajectory or ("circle" if config.scene == "superimposition" else "fixed")
    # linear_tdpa: the bounded linear impedance behind the channel's passivity controllers (fic_core.channel_ports).
    tdpa = config.tdpa or config.controller == "linear_tdpa"
    law = "linear_bounded" if config.controller == "linear_tdpa" else config.controller
    ports = ChannelPorts(tdpa, m["channel_max_damping"], m["channel_energy_window"])
    station = ReplicaStation(ReplicaParameters.from_values({
        **r, "controller": law, "control_rate": config.control_rate, "answer_every_state": True,
        "exchanged_energy_observer": False, **config.replica_overrides}), channel_port=ports.replica)
    master = MasterStation(MasterParameters.from_values({**m, "exchanged_energy_observer": False,
                                                         **config.master_overrides}), channel_port=ports.master)
    if config.operator not in OPERATORS:
        raise ValueError(f"operator must be one of {OPERATORS}, got {config.operator!r}")
    if config.hand not in HANDS:
        raise ValueError(f"hand must be one of {HANDS}, got {config.hand!r}")
    if config.quiet_from is not None and not (math.isfinite(config.quiet_from)
                                              and 0.0 <= config.quiet_from < config.duration):
        raise ValueError(f"quiet_from must be within the run (0 to {config.duration:g} s), got {config.quiet_from}")
    if config.task_variation and config.operator != "closed_loop":
        raise ValueError("task_variation needs the closed-loop operator: a script is timed for the paper's fixed "
                         "circle")
    draws = np.random.default_rng([config.seed, 7919])   # apart from the channel's and the bond's streams
    time_shift = float(draws.uniform(-1.0, 1.0)) * config.operator_timing_jitter
    hand_scale = 1.0 + float(draws.uniform(-1.0, 1.0)) * config.hand_impedance_jitter
    # The device node's parameters as the launcher gives them for this run: the operator, the scene, the video's
    # reaction time (the seed's timing draw is its spread) and the delay the operator has learnt, the quiet tail.
    device_parameters = DeviceNodeParameters.from_values({
        **_parameters("haptic_device.yaml"), "operator_source": config.operator, "scene": config.scene,
        "reaction_time": max(config.reaction_time + time_shift, 0.0), "assumed_one_way_delay": config.delay,
        "quiet_from": -1.0 if config.quiet_from is None else config.quiet_from})
    device = HapticDevice(haptic_device_parameters(device_parameters))
    hand_parameters = device_hand_parameters(device_parameters, hand_scale)
    drawn: dict[str, Any] = {}
    reactive = config.hand == "reactive"
    if reactive:
        reflexes = ReactiveHandParameters.drawn(np.random.default_rng([config.seed, 6007]), hand_parameters)
        drawn["hand"] = dict(vars(reflexes))
        hand: Hand = ReactiveHand(hand_parameters, reflexes)
    else:
        hand = Hand(hand_parameters)
    if config.operator == "closed_loop" and config.scene != "superimposition":
        raise ValueError(f"the closed-loop operator drives the superimposition scene only, not {config.scene!r}")
    if config.operator == "shape_sorting" and config.scene != "shape_sorting":
        raise ValueError(f"the shape-sorting operator drives the shape_sorting scene only, not {config.scene!r}")
    if config.script_path is None and config.scene == "superimposition":
        script = superimposition_script({"one_way_delay": config.delay if config.script_delay is None
                                         else config.script_delay})
    else:
        script = load_script(config.script_path or config_folder() / "operator_scripts" / f"{config.scene}.yaml")
    script.check_workspace(device.parameters.half_extents)
    operator = ScriptedOperator(script)
    watcher = None
    if config.operator == "closed_loop":
        # The seed's timing draw is the reaction time's spread here (the script's clock is not played).
        varying = dict(seed=int(np.random.default_rng([config.seed, 4243]).integers(2 ** 31)),
                       move_amplitude_range=MOVE_AMPLITUDE_RANGE, move_duration_range=MOVE_DURATION_RANGE,
                       move_timing_spread=MOVE_TIMING_SPREAD_S, wander_amplitude_range=WANDER_AMPLITUDE_RANGE_M,
                       wander_period_range=WANDER_PERIOD_RANGE_S, wander_mean_gap=WANDER_MEAN_GAP_S,
                       ) if config.task_variation else {}
        watcher = ClosedLoopOperator(ClosedLoopParameters.from_script_parameters(
            script.parameters, reaction_time=device_parameters.reaction_time,
            assumed_one_way_delay=device_parameters.assumed_one_way_delay, **varying))
    sorter = None
    if config.operator == "shape_sorting":   # the seed's timing draw is the perception delay's spread
        sorter = watcher = ShapeSortingOperator(ShapeSortingParameters(
            perception_delay=device_parameters.reaction_time,
            assumed_one_way_delay=device_parameters.assumed_one_way_delay,
            learnt_stiffness=m["stiffness"], learnt_max_force=m["max_force"], velocity_gain=m["velocity_gain"],
            velocity_deadband=m["velocity_deadband"], handle_half_extents=tuple(device_parameters.half_extents)))
    # The channel node's parameters with this run's link (no routes: the runner hands the messages over itself),
    # each direction on its own seed of the run's.
    link = ChannelParameters.from_values({
        **_parameters("channel.yaml"), "routes": [], "logged_deliveries": [], "delay": config.delay,
        "jitter": config.jitter, "drop_probability": config.drop, "rate_cap_hz": config.rate_cap,
        "blackout_windows": [bound for window in config.blackout_windows for bound in window], "seed": config.seed})
    forward = Channel(channel_config(link))
    backward = Channel(channel_config(link.replaced({"seed": config.seed + 1})))
    # The video shares the backward link (delay, jitter, drops, blackouts) but not the command's rate cap.
    video = Channel(channel_config(link.replaced({"seed": config.seed + 2, "rate_cap_hz": 0.0})))
    source: LapVaryingCircle | None = None   # None: the planner's own (config/planner.yaml's circle or point)
    if trajectory == "circle" and config.task_variation:
        source = LapVaryingCircle.randomised(pl["circle_centre"], np.random.default_rng([config.seed, 31337]),
                                             config.duration, TASK_PERIOD_RANGE_S, TASK_DIAMETER_RANGE_M,
                                             pl["circle_normal"], TASK_PHASE_RANGES_RAD)
        drawn["task"] = dict(periods=source.periods.tolist(), diameters=source.diameters.tolist(), phase=source.phase)
    # The planner node's station, its trajectory's clock on the launcher's origin (shared with the E1 script).
    planner_parameters = PlannerParameters.from_values({
        **pl, "trajectory": "circle" if trajectory == "circle" else "fixed", "start_position": [],
        "start_time": SCRIPT_CIRCLE_START_S - PLANNER_LAG_S if trajectory == "circle" else 0.0})
    if config.quiet_from is not None:   # the quiet tail: the trajectory's clock stops (RunConfig.quiet_from)
        source = StoppedTrajectory(source if source is not None else make_source(planner_parameters),
                                   max(config.quiet_from - planner_parameters.start_time, 0.0))
    planner = PlannerStation(planner_parameters, 0.0, source)
    sim = PandaSimulation(config.scene, config.seed, gravity_compensation=config.dynamics_at_physics_rate)
    # The robot node's station: its stale-command hold (command_timeout), its rule on the state a torque was computed
    # on (command_state_timeout: a torque on an older state is never applied), its velocity reflex.
    robot_changes: dict[str, Any] = {}
    no_state_age_rule = config.robot_command_state_timeout == math.inf
    if config.robot_command_state_timeout is not None and not no_state_age_rule:
        robot_changes["command_state_timeout"] = config.robot_command_state_timeout
    if config.robot_velocity_reflex is not None:
        robot_changes["velocity_reflex"] = config.robot_velocity_reflex
    robot_parameters = RobotParameters.from_values({**_parameters("robot.yaml"), **robot_changes})
    robot = RobotStation.from_parameters(sim, robot_parameters, ARM_JOINT_NAMES, state_age_rule=not no_state_age_rule,
                                         dynamics_at_physics_rate=config.dynamics_at_physics_rate)
    starved = StarvedReplica(config.replica_stalls, config.seed)
    superimposition = config.scene == "superimposition"   # E1: contacts with its fixed obstacle are recorded
    log_ports = []

    device_every, master_every = _every(device_parameters.publish_rate_hz), _every(m["control_rate"])
    network_every, planner_every = _every(m["network_rate"]), _every(pl["publish_rate"])
    delivery_every, wrench_every = _every(link.delivery_rate_hz), _every(robot_parameters.wrench_rate_hz)
    joy_every, camera_every = _every(JOY_RATE_HZ), _every(CAMERA_RATE_HZ)
    log_contact = []
    # The device node's station: the device, the operator's hand and what drives it, the buttons' queue.
    device_station = DeviceStation(device, hand, script=operator, watcher=watcher,
                                   command_timeout=device_parameters.command_timeout, script_origin=time_shift,
                                   quiet_from=config.quiet_from if device_parameters.quiet_from >= 0.0 else None)
    log_t, log_d, log_r, log_f, log_o = [], [], [], [], []
    log_m, log_arm, log_handle, log_target = [], [], [], []
    log_mode, log_sent = [], []
    state = device.state
    steps = int(round(config.duration / STEP))
    # The tail's end (RunConfig.tail_clear): moved on by each contact in the tail, never past one more tail.
    most_steps = steps + (int(round((config.duration - config.quiet_from) / STEP))
                          if config.tail_clear > 0.0 and config.quiet_from is not None else 0)
    if most_steps > steps:   # contact as the run verdict defines it (the verdict is the tail's reader)
        from fic_teleop_tools.verdict.run_verdict import VerdictCriterion
        contact_force = VerdictCriterion.contact_force
    wall = wall_clock.perf_counter()
    for k in range(most_steps):
        if k >= steps:
            break
        now = k * STEP
        ns = k * 1_000_000
        # Operator side (the device node's timer, then the master's): hand, handle, x_M; Eq. 3 back to the device.
        if k % device_every == 0:
            state = device_station.update(now, device_every * STEP if k else 0.0).state
            master.add_pose(state.position, (0.0, 0.0, 0.0, 1.0), now)
            master.add_twist(state.velocity, now)
        if k % joy_every == 0:
            pressed = [0, 0, 0]
            button = device_station.press()
            if button is not None:
                pressed[button] = 1
            master.press(pressed)
        if k % master_every == 0:
            # The master's control tick: its channel port booked (and with TDPA damped) before Eq. 3.
            force, _ = master.update(now, master_every * STEP)
            if force is not None:
                device_station.command(force, now)
        if k % network_every == 0:
            sample = master.teleoperation_command(now)
            if sample is not None:
                forward.push((ns, sample, ports.master.input_energy), now, now)
        if k % planner_every == 0:
            set_point = planner.update(now)
            station.planner_pose(ns, set_point.position, set_point.orientation, now)
            station.planner_acceleration(set_point.acceleration, now)
        if watcher is not None and k % camera_every == 0:
            poses = sim.object_poses()
            video.push(Frame(now, sim.tcp_pose[0], poses["pushable_obstacle"][0]) if sorter is None
                       else SortingFrame(now, sim.tcp_pose[0], np.array([pose[0] for pose in poses.values()])),
                       now, now)
        if watcher is not None and k % delivery_every == 0:
            for delivery in video.pop_due(now):
                watcher.see(now, delivery.payload)
        if k % delivery_every == 0:
            for delivery in forward.pop_due(now):
                stamp_ns, sent, energy = delivery.payload
                station.teleoperation_command(stamp_ns, now, mode=sent.mode, haptic_gain=sent.haptic_gain,
                                              workspace_scale=sent.workspace_scale, velocity_gain=sent.velocity_gain,
                                              handle_position=sent.handle_position,
                                              desired_offset=sent.desired_offset, master_input_energy=energy)
            for delivery in backward.pop_due(now):
                feedback, energy = delivery.payload
                master.add_feedback(feedback, now, replica_input_energy=energy)
        # Robot side: the joint state of step k, the replica's answer, the physics step.
        if k % wrench_every == 0:   # F_R through the driver's declared frame, as the node takes /ft_sensor/wrench
            reading = sim.ft_wrench()
            station.wrench(station.base_frame, reading[:3], reading[3:])
        stall = None
        if config.replica_stalls:
            stall = starved.window(now)
            for torque, state_time, tick_dynamics in starved.arrivals(now):
                if robot.admits(state_time, now):
                    robot.receive(torque, now, tick_dynamics)
            if starved.asleep(now, stall):
                robot.update(now)   # the replica sleeps, or its last torque is still on its way
                continue
            state_time, q_state, qd_state = starved.state(now, stall, sim.joint_positions, sim.joint_velocities)
        else:
            state_time, q_state, qd_state = now, sim.joint_positions, sim.joint_velocities
        # The stream guard sees every state's stamp, as in the node; not the old states of a stall's model, drawn
        # one per wake independently, so out of order, which a reader's queue never delivers.
        if (stall is None or stall.max_state_age == 0.0) and not station.admits_joint_state(state_time, now)[0]:
            robot.update(now)   # never here: the simulated robot is the one writer
            continue
        tick = station.joint_state(state_time, now, q_state, qd_state, ns)
        result = tick.step
        result.torque = tick.command
        # The law's C qd + G at a control tick, for a robot that swaps it for its own at each physics step.
        tick_dynamics = station.tick_dynamics() if config.dynamics_at_physics_rate and result.command is not None \
            else None
        if stall is not None and starved.answered(now, stall, result.torque, state_time, tick_dynamics):
            result.torque = None   # on its way to the robot
        if tick.feedback is not None:   # F_R due back to the master, with the replica port's E_in
            ft_wrench, _ = tick.feedback
            backward.push(tick.feedback, now, now)
            command = station.last_command
            log_t.append(now)
            log_d.append(command.desired_position)
            log_r.append(command.tcp_position.copy())
            log_f.append(ft_wrench)
            log_o.append(station.offset_in_use)
            log_m.append(state.position)
            log_target.append(np.asarray(device_station.target, dtype=float).copy())
            log_mode.append(int(master.mode))
            log_sent.append(master.integrated_offset)
            log_handle.append(device_station.handle_kinetic_energy)
            log_arm.append(robot.arm_kinetic_energy())
            drift = ports.replica.drift
            log_ports.append((ports.master.observer.energy, ports.replica.observer.energy, ports.generated_energy,
                              station.passivity_margin, float(np.linalg.norm(drift)) if drift.size else 0.0))
            # E1's fixed obstacle touches nothing but the robot (static bodies do not collide with the table).
            log_contact.append(superimposition and robot.touches("fixed_obstacle"))
            if most_steps > steps and now >= config.quiet_from and (
                    log_contact[-1] or float(np.linalg.norm(ft_wrench[:3])) >= contact_force):
                steps = min(max(steps, int(math.ceil((now + config.tail_clear) / STEP))), most_steps)
        if result.torque is not None and robot.admits(state_time, now):
            robot.receive(result.torque, now, tick_dynamics)
        robot.update(now)   # the torque taken, or the last one until the watchdog holds the arm
    wall = wall_clock.perf_counter() - wall
    desired, offset = np.array(log_d), np.array(log_o)
    totals = station.totals()
    return RunResult(np.array(log_t), desired, np.array(log_r), np.array(log_f), offset,
                     sim.object_poses(), wall, steps * STEP,
                     totals.limit_violation_ticks, totals.shaped_ticks,
                     np.array(log_m), desired - offset, np.array(log_arm), np.array(log_handle), time_shift,
                     hand_scale, np.array(log_target),
                     totals.passivity_min_margin, totals.passivity_violation_ticks, port_energy=np.array(log_ports),
                     obstacle_contact=np.array(log_contact, dtype=bool),
                     operator_moves=list(watcher.moves_started) if watcher is not None else [], draws=drawn,
                     joint_speed_max=robot.joint_speed_max, robot_watchdog_engagements=robot.watchdog_engagements,
                     stale_torques_refused=robot.refused_torques, replica_holds=totals.holds,
                     command_mode=np.array(log_mode, dtype=int), sent_offset=np.array(log_sent).reshape(-1, 3),
                     quiet_from=config.quiet_from,
                     velocity_reflex_time=None if robot.reflex_event is None else robot.reflex_event.time)


@dataclass
class Agreement:
    """An in-process run against a recorded graph run, on the in-process pose stamps in [start, end]."""

    samples: int
    error_difference_max: float     # max | |e|_in-process - |e|_graph | [m], e = x_d - x_R
    error_difference_rms: float     # [m]
    tcp_difference_max: float       # max |x_R,in-process - x_R,graph| [m]
    desired_difference_max: float   # max |x_d,in-process - x_d,graph| [m]
    graph_error_rms: float          # [m]
    in_process_error_rms: float     # [m]


def agreement(bag: str | Path, result: RunResult, start: float = 0.5, end: float | None = None) -> Agreement:
    """Compare ``result`` with the bag of a lockstep graph run of the same configuration (the report's tracking
    error: x_d and x_R as the replica published them), from ``start`` to ``end`` (None: the end of both)."""
    from fic_teleop_tools.report.bag_data import load_bag
    from fic_teleop_tools.report.metrics import _tracking_error

    data = load_bag(bag)
    graph_time, graph_error, _ = _tracking_error(data)

    def positions(topic: str) -> tuple[np.ndarray, np.ndarray]:
        series = data.series[topic]
        order = np.argsort(series.stamp, kind="stable")
        return series.stamp[order], np.column_stack([series.values[axis][order] for axis in "xyz"])

    tcp_time, tcp = positions("/replica/tcp_pose")
    desired_time, desired = positions("/replica/desired_pose")
    last = min(result.time[-1], graph_time[-1], tcp_time[-1], desired_time[-1])
    window = (result.time >= start) & (result.time <= (last if end is None else min(end, last)))
    times = result.time[window]
    graph = np.interp(times, graph_time, graph_error)
    mine = result.tracking_error[window]

    def apart(stamps: np.ndarray, values: np.ndarray, ours: np.ndarray) -> float:
        theirs = np.column_stack([np.interp(times, stamps, values[:, axis]) for axis in range(3)])
        return float(np.linalg.norm(theirs - ours[window], axis=1).max())

    difference = np.abs(mine - graph)
    return Agreement(int(window.sum()), float(difference.max()), float(np.sqrt(np.mean(difference ** 2))),
                     apart(tcp_time, tcp, result.tcp), apart(desired_time, desired, result.desired),
                     float(np.sqrt(np.mean(graph ** 2))), float(np.sqrt(np.mean(mine ** 2))))
