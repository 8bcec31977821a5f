"""ROS 2 shell around the simulated Panda (mujoco_panda.py): the robot as a real Franka driver presents it.

Publishes ``/joint_states`` (effort = torque applied) every physics step (realtime: every
``1000 / joint_state_rate_hz`` steps, 1 kHz by default as a Franka's broadcaster), ``/ft_sensor/wrench`` (environment
wrench at the TCP, frame panda_link0) every ``1000 / wrench_rate_hz`` steps (250 Hz by default: the wrench feeds
the haptic feedback, which runs at 250 Hz, and on this 2-core machine each 1 kHz stream costs about a third of a
core with its subscribers, docs/CONVENTIONS.md), ``/clock``, ``/sim/step_lateness``, ``/sim/object_poses``,
``/sim/tcp_pose`` and ``/diagnostics``; takes ``/effort_controller/commands`` (7 torques, ros2_control's
effort-controller convention), so a real Panda driver can stand in its place.

One thread steps the physics and publishes everything (so all rates are counted in physics steps and nothing
reads the model while it moves); the executor thread only receives commands. Modes (stepping.py):
- realtime: steps paced by the wall clock at 1 kHz, zero-order hold on the last command. Header stamps are the
  simulation's 1 ms step grid laid on the wall clock at the first step (so gaps are countable and stamps compare
  with other nodes' wall-clock stamps); /clock (sim time) is published at ``realtime_clock_rate_hz``.
- lockstep: after publishing the state of step k, wait for a command that arrives after that publication, then
  step; a wait longer than ``lockstep_timeout`` (wall clock) is counted and the step proceeds on the last command.
  Stamps are simulation time and /clock is published every ``1000 / lockstep_clock_rate_hz`` steps: run every other
  node with use_sim_time:=true. With ``step_clock_topic`` set, the time of every step also goes out there, for the
  node that answers each state (its /clock remapped there). Both go out before the state of their step.
  Until the first command arrives the simulation waits at t=0 (re-publishing the initial state every
  ``lockstep_timeout``), so a run does not depend on how long the controller took to start; the answers to those
  copies are all drained (LockstepGate.wait_quiet) before the first step, so none is taken for a later step.
  ``lockstep_peers`` (header-stamped topics of the nodes that only follow /clock: the device, the master, the
  planner) are waited for too: no step past t until each has published a stamp >= t - ``lockstep_peer_lag``
  (peer_barrier.py), so that the operator's side keeps up with the simulation instead of falling behind it.
  A command that names the joint state it was computed on (fic_core.command_stamp, the replica's) answers that
  state; one that names none is taken in order, the n-th command as the answer to the n-th state (a late answer
  after a timeout is not mistaken for the next state's). While the watchdog holds (commands stopped), steps are
  paced by the wall clock instead of waiting: the world and /clock keep moving for whoever is still listening.

Safety (robot_station.py, the station the in-process runner steps too; watchdog.py, velocity_reflex.py): commands
older than ``command_timeout`` (wall seconds in realtime; in lockstep simulated seconds since the state the newest
command was computed on) are replaced by the hold torque (gravity compensation + damping); each transition is
logged once.
Commands with NaN/Inf or a length other than 7 are rejected with an error log and never reach the physics.
Realtime: a command that names the joint state it was computed on (the replica's do, fic_core.command_stamp) is
refused when that state is older than ``command_state_timeout`` against the newest state published: it is never
applied and does not release the watchdog, so neither a starved controller's late torque nor the first one after a
hold acts on an arm that has moved on (docs/SECURITY.md). Lockstep needs no such rule: the n-th answer is taken for
the n-th state, and the simulation waits for it.
"""
from __future__ import annotations

import threading
import time

import numpy as np
import rclpy
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Pose, PoseArray, PoseStamped, WrenchStamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray, Header

from fic_core.command_stamp import stamp_ns as command_state_stamp_ns
from fic_core.errors import FicInputError
from fic_core.panda_description import ARM_JOINT_NAMES
from fic_teleop_runtime import qos, stop_signals
from fic_teleop_runtime.cdr_header import header_stamp, stamp_seconds
from fic_teleop_runtime.driver_topics import FRANKA_CONVENIENCE_QOS, FRANKA_ROS2, ROBOT_INTERFACES, SYSTEM_DEFAULTS_QOS
from fic_teleop_runtime.in_process_link import LINK
from fic_teleop_runtime.message_types import message_class
from fic_teleop_runtime.node_main import NodeEntry, run_entry
from fic_teleop_runtime.parameters import Schema, declare
from fic_teleop_runtime.record_batch import BatchedPublisher
from sim_bridge.os_thread import name_os_thread
from sim_bridge.robot.mujoco_panda import TIMESTEP, PandaSimulation
from sim_bridge.robot.peer_barrier import PeerBarrier
from sim_bridge.robot.render import StateTape, check_video_path, default_view, launch_viewer, render_tape
from sim_bridge.robot.robot_parameters import ROBOT_PARAMETERS, SUBSCRIBER_WAIT_S, RobotParameters
from sim_bridge.robot.robot_station import RobotStation, RobotUpdate
from sim_bridge.robot.scenes import SCENE_NAMES
from sim_bridge.robot.stepping import STEPPING_MODES, LockstepCommand, LockstepGate, RealtimePacer, ZeroOrderHold
from sim_bridge.robot.watchdog import WatchdogEvent

# 1 kHz robot streams (docs/CONVENTIONS.md): RELIABLE, KEEP_LAST 1000. A reliable writer overwrites samples a
# slow reader has not acknowledged once its history is full, so a deep history (one second, only memory) is what
# lets a recorder on a busy machine lose none; a late command is superseded by the next one anyway. The status
# streams are written with the same history.
ROBOT_STREAM_QOS = qos.ROBOT_STREAM
NEWEST_COMMAND_QOS, STATUS_QOS, DIAGNOSTICS_QOS = qos.NEWEST, qos.STREAM_WRITER, qos.DIAGNOSTICS
# Peers' stamps: only the newest matters; best effort matches reliable and best-effort publishers alike.
PEER_QOS = qos.best_effort(10)

BASE_FRAME = "panda_link0"
STEPS_PER_SECOND = round(1.0 / TIMESTEP)
STEP_NS = round(TIMESTEP * 1e9)   # a step on the stamp grid [ns]

SCHEMA = Schema("robot.yaml", ROBOT_PARAMETERS.values())


# The physics thread's name as the OS shows it (top -H, /proc): the launcher gives it real-time priority by it.
PHYSICS_THREAD_NAME = "physics"


def _time_from_steps(steps: int) -> Time:
    """Exact simulation time of a step count (no float rounding in the stamps)."""
    nanoseconds = steps * round(TIMESTEP * 1e9)
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def _every(rate_hz: float) -> int:
    """Steps between publications at ``rate_hz`` (0: never)."""
    return 0 if rate_hz <= 0.0 else max(1, round(STEPS_PER_SECOND / rate_hz))


class RobotNode(Node):
    def __init__(self, **node_options) -> None:  # node_options: rclpy Node keywords (node_group.py)
        super().__init__("robot_sim", **node_options)
        p = self._declare_parameters()
        self._mode = p.mode
        self._sim = PandaSimulation(p.scene, p.seed, p.initial_configuration,
                                    gravity_compensation=p.gravity_compensation)
        self._franka = p.driver_interface == "franka_ros2"
        self._hold_on_stale = p.hold_on_stale_commands
        self._scene = p.scene
        self._lockstep_timeout = p.lockstep_timeout
        self._lockstep_subscribers = p.lockstep_subscribers
        self._gate = LockstepGate()
        self._barrier = (PeerBarrier(p.lockstep_peers, p.lockstep_peer_lag, p.lockstep_peer_timeout)
                         if self._mode == "lockstep" and p.lockstep_peers else None)
        self._hold = ZeroOrderHold()
        self._pacer = RealtimePacer(TIMESTEP)
        lockstep = self._mode == "lockstep"
        self._clock_every = _every(p.lockstep_clock_rate_hz if lockstep else p.realtime_clock_rate_hz)
        self._lateness_every = _every(p.lateness_rate_hz)
        self._joint_state_every = 1 if lockstep else _every(p.joint_state_rate_hz)
        self._joint_state_phase = 0
        self._wrench_every = _every(p.wrench_rate_hz)
        self._poses_every = _every(p.object_pose_rate_hz)
        self._diagnostics_every = _every(p.diagnostics_rate_hz)
        self._video_path = p.render_video_path or None
        self._snapshot_dir = p.snapshot_dir or None
        if self._video_path:
            try:
                check_video_path(self._video_path)  # refuse an unwritable format now, not after the run
            except ValueError as exc:
                raise FicInputError(f"render_video_path: {exc}") from exc
        self._tape = (StateTape(1.0 / p.video_frame_rate_hz) if (self._video_path or self._snapshot_dir) else None)
        if self._tape is not None:
            self._tape.maybe_record(self._sim.data)  # the initial state is the first frame
        self._video_fps = p.video_frame_rate_hz
        self._snapshot_interval = p.snapshot_interval
        self._viewer = launch_viewer(self._sim.model, self._sim.data) if p.viewer else None
        if p.viewer and self._viewer is None:
            self.get_logger().warning("viewer requested but there is no display: running without it")

        self._rejected_commands = 0
        self._accepted_commands = 0
        self._last_command_count = 0
        self._last_command: np.ndarray | None = None
        self._applied = LockstepCommand(self._gate)   # lockstep: the command the arm gets
        self._stop = threading.Event()
        self._wall_epoch_ns = self.get_clock().now().nanoseconds

        # The franka_ros2 twin (driver_topics.py): its topics, QoS and frames; the arm compensates its gravity.
        franka = FRANKA_ROS2
        # The two physics-rate streams reach the recorder in batches (record_batch.py); the twin speaks as the real
        # driver does, one message a sample.
        batch_period = 0.0 if self._franka else p.record_batch_period
        self._joint_state_pub = BatchedPublisher(
            self, JointState, franka.joint_states if self._franka else "/joint_states",
            SYSTEM_DEFAULTS_QOS if self._franka else ROBOT_STREAM_QOS, batch_period)
        self._wrench_pub = BatchedPublisher(
            self, WrenchStamped, franka.external_wrench if self._franka else "/ft_sensor/wrench",
            FRANKA_CONVENIENCE_QOS if self._franka else ROBOT_STREAM_QOS, batch_period)
        self._slow_joint_state_pub = (self.create_publisher(JointState, franka.slow_joint_states, SYSTEM_DEFAULTS_QOS)
                                      if self._franka else None)
        self._slow_every = _every(franka.slow_joint_states_rate_hz)
        self._clock_pub = self.create_publisher(Clock, "/clock", ROBOT_STREAM_QOS)
        # Lockstep: the node that answers every state reads the time of each step here, so that /clock, which wakes
        # every node that follows the simulation, can go out at the coarser lockstep_clock_rate_hz
        # (docs/CONVENTIONS.md, "Time").
        self._step_clock_pub = (self.create_publisher(Clock, p.step_clock_topic, ROBOT_STREAM_QOS)
                                if lockstep and p.step_clock_topic else None)
        self._lateness_pub = self.create_publisher(Float64, "/sim/step_lateness", STATUS_QOS)
        self._object_poses_pub = self.create_publisher(PoseArray, "/sim/object_poses", STATUS_QOS)
        self._tcp_pose_pub = self.create_publisher(PoseStamped, "/sim/tcp_pose", STATUS_QOS)
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", DIAGNOSTICS_QOS)
        # Realtime: only the newest command matters (zero-order hold), and a reliable reader would hold every later
        # command back behind one lost sample until it is repaired. Lockstep: every answer counts, in order.
        command_qos = ROBOT_STREAM_QOS if self._mode == "lockstep" else (
            SYSTEM_DEFAULTS_QOS if self._franka else NEWEST_COMMAND_QOS)
        self._controller_in_process = p.controller_in_process
        if self._controller_in_process:  # the replica of this process calls _on_command (in_process_link.py)
            if self._franka or self._mode != "realtime":
                raise FicInputError("controller_in_process needs mode realtime and driver_interface sim (lockstep "
                                    "answers each state over the step clock; a driver twin speaks DDS as the real "
                                    "driver does)")
            LINK.command_reader = self._on_command
        else:
            self.create_subscription(Float64MultiArray, "/effort_controller/commands", self._on_command, command_qos)
        self._unresolved_peers = list(self._barrier.topics) if self._barrier is not None else []
        self._peer_subscriptions: dict[str, object] = {}   # peer topic -> our raw subscription (executor thread)
        if self._unresolved_peers:  # their types come from the graph, once their publishers are up
            self._peer_timer = self.create_timer(0.2, self._subscribe_peers)

        self._joint_state = JointState()
        self._joint_state.header.frame_id = franka.joint_states_frame if self._franka else BASE_FRAME
        self._joint_state.name = ([f"{franka.joint_prefix}_joint{i}" for i in range(1, 8)] if self._franka
                                  else list(ARM_JOINT_NAMES))
        # The watchdog and the state-age rule (on the stamp grid: nanoseconds), the reflex and the hold.
        self._station = RobotStation.from_parameters(self._sim, p, self._joint_state.name, nanosecond_stamps=True)
        self._wrench_frame = franka.external_wrench_frame if self._franka else BASE_FRAME
        self._wrench = WrenchStamped(header=Header(frame_id=self._wrench_frame))

        objects = ", ".join(self._sim.layout.movable_bodies) or "none"
        self.get_logger().info(
            f"robot_sim ready: scene {self._scene}, mode {self._mode}, seed {p.seed}, watchdog "
            f"{p.command_timeout:.3f} "
            f"s{'' if self._hold_on_stale else ' (off: commands held, as a forward controller does)'}; "
            f"driver interface {p.driver_interface}, gravity "
            f"{'compensated by the arm' if p.gravity_compensation else 'in the command'}; "
            f"/sim/object_poses order: {objects}")
        self._thread = threading.Thread(target=self._run, name=PHYSICS_THREAD_NAME, daemon=True)

    def start_physics(self) -> None:
        """Start stepping (node_main runs it once every node of the process is built: a replica built beside it, in
        the same interpreter, had the first steps run up to 100 ms behind the wall clock)."""
        self._thread.start()

    # --- parameters --------------------------------------------------------------------------------------------
    def _declare_parameters(self) -> RobotParameters:
        # Every row with its config/robot.yaml value; unknown keys refused.
        p = RobotParameters.from_values(declare(self, SCHEMA))
        if p.driver_interface not in ROBOT_INTERFACES:
            raise FicInputError(f"driver_interface must be one of {ROBOT_INTERFACES}, got {p.driver_interface!r}")
        if p.scene not in SCENE_NAMES:
            raise FicInputError(f"scene must be one of {SCENE_NAMES}, got {p.scene!r}")
        if p.mode not in STEPPING_MODES:
            raise FicInputError(f"mode must be one of {STEPPING_MODES}, got {p.mode!r}")
        steps = STEPS_PER_SECOND / p.lockstep_clock_rate_hz
        if abs(steps - round(steps)) > 1e-9:
            raise FicInputError(f"lockstep_clock_rate_hz must divide {STEPS_PER_SECOND:g}, got "
                                f"{p.lockstep_clock_rate_hz:g}")
        return p.replaced({"lockstep_peers": [topic for topic in p.lockstep_peers if topic]})

    # --- commands (executor thread) ------------------------------------------------------------------------------
    def _on_command(self, message: Float64MultiArray) -> None:
        command = np.asarray(message.data, dtype=np.float64)
        if command.shape != (7,) or not np.isfinite(command).all():
            self._rejected_commands += 1
            reason = (f"{command.size} values instead of 7" if command.shape != (7,)
                      else f"non-finite values {command.tolist()}")
            self.get_logger().error(f"rejected torque command on /effort_controller/commands: {reason}; "
                                    "it is not applied", throttle_duration_sec=1.0)
            return
        if self._mode == "realtime" and self._computed_on_old_state(message):
            return
        self._accepted_commands += 1
        self._hold.update(command, time.monotonic())
        self._gate.deliver(command, _named_state_ns(message))

    def _computed_on_old_state(self, message: Float64MultiArray) -> bool:
        """Whether the command names a joint state older than command_state_timeout against the newest one published
        (both on the simulation's stamp grid); counted and said (throttled) if so."""
        state_ns = _named_state_ns(message)
        if state_ns is None:
            return False
        newest_ns = self._wall_epoch_ns + self._sim.steps * round(TIMESTEP * 1e9)
        station = self._station
        if station.admits(state_ns, newest_ns):
            return False
        self.get_logger().warning(
            f"refused a torque command computed on a joint state {(newest_ns - state_ns) * 1e-6:.1f} ms old "
            f"(command_state_timeout {station.command_state_timeout * 1e-6:g} ms; {station.refused_torques} so "
            "far): not applied", throttle_duration_sec=1.0)
        return True

    # --- lockstep peers (executor thread) -------------------------------------------------------------------------
    def _subscribe_peers(self) -> None:
        """Subscribe to each peer topic whose type the graph now knows (raw: only the header stamp is read)."""
        types = dict(self.get_topic_names_and_types())
        for topic in list(self._unresolved_peers):
            names = types.get(topic)
            if not names:
                continue
            self._unresolved_peers.remove(topic)
            try:
                message_type = message_class(names[0])
            except FicInputError as exc:  # a type this workspace cannot load
                self.get_logger().error(f"lockstep: cannot wait for peer {topic}: its type {names[0]} does not "
                                        f"load here ({exc}); stepping without it")
                continue
            self._peer_subscriptions[topic] = self.create_subscription(
                message_type, topic, lambda data, topic=topic: self._on_peer(topic, data), PEER_QOS, raw=True)
            self.get_logger().info(f"lockstep: waiting for peer {topic} ({names[0]}) to keep up")
        if not self._unresolved_peers:
            self._peer_timer.cancel()

    def _on_peer(self, topic: str, data: bytes) -> None:
        stamp = header_stamp(data)
        if stamp is not None:
            self._barrier.stamp(topic, stamp_seconds(stamp))

    # --- physics thread ------------------------------------------------------------------------------------------
    def _run(self) -> None:
        name_os_thread(PHYSICS_THREAD_NAME)
        try:
            if self._mode == "lockstep":
                self._run_lockstep()
            else:
                self._run_realtime()
        except Exception as exc:  # noqa: BLE001  (a context shut down under a publish ends the thread quietly)
            if not self._stop.is_set() and rclpy.ok(context=self.context):
                self.get_logger().fatal(f"physics thread failed: {exc!r}; the node stops (exit 1)")
                stop_signals.fail()   # not a node that runs on with no physics
                raise

    def _run_realtime(self) -> None:
        # Stamps are the simulation's own 1 ms grid laid on the wall clock from the first step: comparable with
        # every other node's wall-clock stamps (to within the step lateness) and exact enough for a recorder or
        # report to count a missing joint state as a gap in the grid.
        step_ns = round(TIMESTEP * 1e9)
        start_ns = self.get_clock().now().nanoseconds // step_ns * step_ns  # on a whole step of the wall clock
        self._wall_epoch_ns = start_ns - self._sim.steps * step_ns
        # /joint_states on the steps whose stamps are whole multiples of its period: a recorder or report counts
        # gaps on that grid as on the 1 ms one.
        self._joint_state_phase = (self._wall_epoch_ns // step_ns) % self._joint_state_every
        self._publish_state()
        while not self._stop.is_set():
            lateness = self._pacer.wait_next()
            command, arrival, count = self._hold.latest()
            if count != self._last_command_count:
                self._last_command_count = count
                self._log_event(self._station.receive(command, arrival))
            self._log_update(self._station.update(time.monotonic()))
            self._after_step(lateness)

    def _run_lockstep(self) -> None:
        # Nothing moves before every expected reader of /joint_states is there (the replica and the recorder): a
        # recorder that subscribes late would miss the first steps of the run. Nor before this node's subscription
        # to every lockstep peer's topic has matched the peer's publisher; the barrier then expects each peer from
        # t = 0 (peer_barrier.py). A planner or device that started late (a loaded machine: 2-3 s of wall time)
        # had joined the run at 0.45-0.5 s of simulated time, and a device matched after the first step was 99 ms
        # behind: the run no longer depended on its seed alone.
        peers = self._barrier.topics if self._barrier is not None else ()

        def missing() -> list[str]:
            readers = self._joint_state_pub.reader_count()
            absent = [] if readers >= self._lockstep_subscribers else \
                [f"{readers} of {self._lockstep_subscribers} /joint_states readers"]
            subscriptions = dict(self._peer_subscriptions)   # filled by the executor thread
            return absent + [f"no matched publisher of {topic}" for topic in peers
                             if topic not in subscriptions or subscriptions[topic].get_publisher_count() < 1]

        deadline = time.monotonic() + SUBSCRIBER_WAIT_S
        while missing() and time.monotonic() < deadline and not self._stop.is_set():
            time.sleep(0.05)
        absent = missing()
        if absent:
            self.get_logger().warning(f"lockstep: {', '.join(absent)} after {SUBSCRIBER_WAIT_S:g} s; starting anyway")
        for topic in peers:
            if topic in self._peer_subscriptions:
                self._barrier.expect(topic, self._sim.time)
        self._log_event(self._station.check_watchdog(self._sim.time))
        late_steps = 0  # consecutive steps whose wait saw only late answers
        while not self._stop.is_set():
            self._gate.state_published(self._sim.steps * STEP_NS)  # before publishing: an instant answer must count
            self._publish_state()
            started = self._last_command is not None
            if started and self._station.holding:
                self._pacer.wait_next()  # held after commands stopped: keep the world moving at wall-clock pace
                command, fresh = self._gate.poll_any()
                if fresh:  # the controller is back: take its burst of answers, then count afresh
                    command = self._gate.wait_quiet(self._lockstep_timeout)
                    self._gate.resync()
            else:  # waiting for the first command is not a late controller: not counted as a timeout
                late_before = self._gate.late_answers
                command, fresh = self._gate.wait(self._lockstep_timeout, count_timeout=started)
                if fresh and not started:  # answers to every copy of the initial state: take them all
                    command = self._gate.wait_quiet(self._lockstep_timeout)
                    self._gate.resync()
                late_steps = 0 if (fresh or self._gate.late_answers == late_before) else late_steps + 1
                if late_steps >= 3:  # answers keep coming one state behind: the counts drifted, realign them
                    self._gate.resync()
                    late_steps = 0
            if self._stop.is_set():
                return
            if not fresh and not started:
                continue  # no command ever: wait at t=0, re-publishing the initial state
            station = self._station
            since = self._applied.take(command, fresh, self._sim.time, station.holding, station.command_timeout)
            if since is not None:   # a newer torque: followed, its age counted from ``since``
                self._log_event(station.receive(self._applied.command, since))
            self._last_command = self._applied.command
            if self._barrier is not None:
                for topic in self._barrier.wait(self._sim.time):
                    self.get_logger().warning(
                        f"lockstep: peer {topic} held the simulation at t = {self._sim.time:.3f} s for more than "
                        f"lockstep_peer_timeout; not waiting for it until it catches up")
            self._log_update(station.update(self._sim.time))
            self._after_step(None)

    def _log_update(self, update: RobotUpdate) -> None:
        """A step's watchdog transition, and the velocity reflex's trip (said once, at once in /diagnostics)."""
        self._log_event(update.watchdog)
        event = update.reflex
        if event is not None:
            self.get_logger().error(f"{event.message} (t = {event.time:.3f} s)")
            self._publish_diagnostics()   # in the bag at once, not at the next 1 Hz status

    def _after_step(self, lateness: float | None) -> None:
        steps = self._sim.steps
        if self._mode == "realtime":
            if (steps + self._joint_state_phase) % self._joint_state_every == 0:
                self._publish_state()
            elif steps % self._wrench_every == 0:
                self._publish_wrench(self._stamp())
        # Both clocks before the state of this step (published next): no node gets a message about step t before
        # its clock reads t; the step clock first, so the answering node has its time before a follower reacts.
        on_clock = bool(self._clock_every) and steps % self._clock_every == 0
        if self._step_clock_pub is not None or on_clock:
            clock = Clock(clock=_time_from_steps(steps))   # one message for both clocks of this step
            if self._step_clock_pub is not None:
                self._step_clock_pub.publish(clock)
            if on_clock:
                self._clock_pub.publish(clock)
        if self._lateness_every and lateness is not None and steps % self._lateness_every == 0:
            # The worst step lateness over the last publication period (the 10 s p50/p99 go to /diagnostics).
            self._lateness_pub.publish(Float64(data=self._pacer.recent_max(self._lateness_every)))
        if self._poses_every and steps % self._poses_every == 0:
            self._publish_poses()
        if self._diagnostics_every and steps % self._diagnostics_every == 0:
            self._publish_diagnostics()
        for event in self._sim.drain_bond_events():
            self.get_logger().info(event)
        if self._tape is not None:
            self._tape.maybe_record(self._sim.data)
        if self._viewer is not None and steps % 33 == 0 and self._viewer.is_running():
            self._viewer.sync()

    def _stamp(self) -> Time:
        if self._mode == "lockstep":
            return _time_from_steps(self._sim.steps)
        nanoseconds = self._wall_epoch_ns + self._sim.steps * round(TIMESTEP * 1e9)
        return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)

    def _publish_state(self) -> None:
        stamp = self._stamp()
        if self._sim.steps % self._wrench_every == 0:  # first: a controller in this process steps on both
            self._publish_wrench(stamp)
        self._joint_state.header.stamp = stamp
        self._joint_state.position = self._sim.joint_positions.tolist()
        self._joint_state.velocity = self._sim.joint_velocities.tolist()
        self._joint_state.effort = self._sim.applied_torque.tolist()
        controller = LINK.joint_state_reader if self._controller_in_process else None
        if controller is not None:  # the replica's control step, here in the physics thread; its torque comes back
            controller(self._joint_state)   # through _on_command before the next step
        self._joint_state_pub.publish(self._joint_state)
        if self._slow_joint_state_pub is not None and self._sim.steps % self._slow_every == 0:
            self._slow_joint_state_pub.publish(self._joint_state)  # joint_state_publisher's 30 Hz copy

    def _publish_wrench(self, stamp: Time) -> None:
        wrench = self._sim.ft_wrench()
        controller = LINK.wrench_reader if self._controller_in_process else None
        # The replica keeps the message it is handed (its F_R): a new one each time then.
        message = self._wrench if controller is None else WrenchStamped(header=Header(frame_id=self._wrench_frame))
        message.header.stamp = stamp
        force, torque = message.wrench.force, message.wrench.torque
        force.x, force.y, force.z, torque.x, torque.y, torque.z = wrench.tolist()
        if controller is not None:
            controller(message)
        self._wrench_pub.publish(message)

    def _publish_poses(self) -> None:
        stamp = self._stamp()
        array = PoseArray()
        array.header.stamp, array.header.frame_id = stamp, BASE_FRAME
        for position, quaternion in self._sim.object_poses().values():
            array.poses.append(_pose(position, quaternion))
        self._object_poses_pub.publish(array)
        tcp = PoseStamped()
        tcp.header.stamp, tcp.header.frame_id = stamp, BASE_FRAME
        tcp.pose = _pose(self._sim.tcp_pose[0], self._sim.tcp_quaternion)
        self._tcp_pose_pub.publish(tcp)

    def _log_event(self, event: WatchdogEvent | None) -> None:
        if event is None:
            return
        if event.engaged:
            self.get_logger().warning(f"watchdog: {event.message}")
        else:
            self.get_logger().info(f"watchdog: {event.message}")

    def statistics(self) -> dict[str, str]:
        summary = self._pacer.summary()
        values = {
            "mode": self._mode,
            "scene": self._scene,
            "sim_time": f"{self._sim.time:.3f}",
            "steps": str(self._sim.steps),
            "watchdog_holding": str(self._station.holding),
            "watchdog_engagements": str(self._station.watchdog_engagements),
            "reflex": "" if self._station.reflex_event is None else self._station.reflex_event.message,
            "commands_accepted": str(self._accepted_commands),
            "commands_rejected": str(self._rejected_commands),
            "commands_on_old_states": str(self._station.refused_torques),
            "lockstep_answered": str(self._gate.answered_steps),
            "lockstep_timeouts": str(self._gate.timeouts),
        }
        if self._barrier is not None:
            values.update({"lockstep_peer_waits": str(self._barrier.waits),
                           "lockstep_peer_wait_s": f"{self._barrier.wait_time:.3f}",
                           "lockstep_peer_stalls": str(self._barrier.stalls),
                           "lockstep_peers_stalled": ",".join(self._barrier.stalled)})
        if self._mode == "realtime":
            values.update({"lateness_p50_ms": f"{summary.p50 * 1e3:.3f}", "lateness_p99_ms": f"{summary.p99 * 1e3:.3f}",
                           "lateness_max_ms": f"{summary.max * 1e3:.3f}",
                           "achieved_rate_hz": f"{summary.achieved_rate:.1f}",
                           "overruns": str(summary.overruns)})
        bond = self._sim.bond_state
        if bond is not None:
            values.update({"bonded_piece": bond.bonded_piece or "", "bond_force_n": f"{bond.bond_force:.2f}",
                           "bond_break_threshold_n": f"{bond.break_threshold:.2f}",
                           "bonds_formed": str(bond.bonds_formed),
                           "bond_breaks": str(bond.breaks)})
        return values

    def _publish_diagnostics(self) -> None:
        values = self.statistics()
        array = DiagnosticArray()
        array.header.stamp = self._stamp()
        holding = self._station.holding
        reflex = self._station.reflex_tripped
        status = DiagnosticStatus(
            level=DiagnosticStatus.ERROR if reflex else
            DiagnosticStatus.WARN if holding or self._rejected_commands else DiagnosticStatus.OK,
            name="robot_sim", hardware_id="panda_mujoco",
            message="stopped by its velocity reflex" if reflex else
            "holding: torque commands stale" if holding else "following torque commands")
        status.values = [KeyValue(key=key, value=value) for key, value in values.items()]
        array.status = [status]
        self._diagnostics_pub.publish(array)

    # --- shutdown ------------------------------------------------------------------------------------------------
    def stop(self) -> None:
        """Stop the physics thread, then write the pictures of the run (if asked)."""
        self._stop.set()
        self._gate.interrupt()
        if self._barrier is not None:
            self._barrier.interrupt()
        if self._thread.is_alive():   # not started if the process stopped while its nodes were being built
            self._thread.join(timeout=5.0)
        if self._viewer is not None:
            self._viewer.close()
        if self._tape is not None and len(self._tape):
            written = render_tape(self._sim.model, self._tape, default_view(self._scene), self._video_path,
                                  self._snapshot_dir, self._snapshot_interval, self._video_fps)
            for path in written:
                rclpy.logging.get_logger("sim_bridge.robot.robot_node").info(f"wrote {path}")


def _named_state_ns(message: Float64MultiArray) -> int | None:
    """The joint state stamp [ns] a torque command names (fic_core.command_stamp), None if it names none."""
    if len(message.layout.dim) != 1:
        return None
    return command_state_stamp_ns(message.layout.dim[0].label)


def _pose(position: np.ndarray, quaternion_wxyz: np.ndarray) -> Pose:
    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = position.tolist()
    w, x, y, z = quaternion_wxyz.tolist()
    pose.orientation.w, pose.orientation.x, pose.orientation.y, pose.orientation.z = w, x, y, z
    return pose


def main(args: list[str] | None = None) -> None:
    run_entry(ENTRY, args)


def _stopped(node: RobotNode) -> None:
    node.stop()
    rclpy.logging.get_logger("sim_bridge.robot.robot_node").info(f"robot_sim stopped: {node.statistics()}")


# Two threads share the GIL here (physics, and the executor receiving commands): the default 5 ms switch interval
# would let a busy executor hold the physics thread past several 1 ms steps.
ENTRY = NodeEntry(RobotNode, "robot_sim", stopped=_stopped, switch_interval=0.0002, started=RobotNode.start_physics)


if __name__ == "__main__":
    main()
