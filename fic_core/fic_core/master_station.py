"""The master side's logic (paper Eq. 3 and Sec. II-C) around fic_core.MasterLaw: what the master node runs and
the in-process runner steps.

    handle pose x_M, twist --> the handle velocity (the device's twist while fresh, else differences of poses)
    F_R (through the channel) --> feedback freshness (older than feedback_timeout: rendered as zero, said once)
    --> MasterLaw f = FIC(-x_M) + K_H F_R  (zero while the pose is older than pose_timeout)
    x_M --> TeleoperationCommandIntegrator --> x_d' (offset or velocity mode, at the network rate)
    operator buttons (edges, fic_core.operator_buttons) --> mode toggle, K_H steps, the clutch

A control tick is one call, ``update``, which owns its order: the channel's master port booked on the F_R held and
the rate of x_d' (fic_core.channel_ports; with TDPA the F_R Eq. 3 renders is the port's damped one), then Eq. 3
(``force``), then the handle FIC's port booked by the exchanged-energy observer (fic_core.exchanged_energy_ports,
when ``exchanged_energy_observer`` is on). F_R arrives with ``add_feedback``, which also hands it to the port.

The operator's tools (beyond the paper; docs/TOOLS.md, "The operator's tools"), each a parameter settable live:
- the clutch (indexing): while held, x_d' holds still and the handle feels its own FIC only (F_R and the guidance
  answer a motion the handle no longer makes); released, the handle is engaged again, re-anchored so that x_d'
  continues from where it stood and the handle's new position is the offset origin;
- homing (fic_core.handle_homing): the handle is driven to the centre at a bounded speed, x_d' held, and engaged
  only once homed; the ``homing`` parameter reads true while it runs;
- the force scale k_F beside the motion scale s_M (``workspace_scale``), with the loop-gain bound
  k_F s_M K_H <= 1 (fic_core.master): a change past it is refused, a K_H from a button or a topic is clamped to it;
- a guidance fixture (fic_core.guidance_fixture), a plane or a line in x_d' coordinates: the x_d' sent to the
  replica is projected onto it, and its guidance force is added to Eq. 3's while the handle is engaged. Switching
  a fixture on, off or elsewhere moves the sent goal to its new place at ``GOAL_TRANSITION_SPEED``, never in a jump.

The station takes its parameters as one typed object, ``MasterParameters``, generated from the master's table
(``MASTER_PARAMETERS``, the rows the master node declares) and checked against it when built. ``configure`` is the
parameter dispatch: a change of the handle's profile rebuilds its attractor (phase reset), the others are applied in
place; every value is checked before any is applied. Notices (what the caller should
log) come back as (level, text), level one of info, warning and repeated_warning (one said at every tick while
its cause lasts: to be throttled).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import IntEnum
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .attractor import FractalAttractor
from .channel_ports import CHANNEL_PORT_NUMBERS, CHANNEL_PORT_SWITCHES, MasterChannelPort, port_velocity
from .errors import FicInputError, finite_array, finite_scalar
from .exchanged_energy_ports import EXCHANGED_ENERGY_SWITCHES, MasterExchangedEnergy
from .guidance_fixture import FixtureKind, GuidanceFixture, fixture_kind
from .handle_homing import HandleHoming
from .master import MasterLaw, checked_loop_gain, haptic_gain_ceiling, loop_gain
from .norm_bound import norm_bounded
from .operator_buttons import HAPTIC_GAIN_STEP, ButtonEdges, OperatorButton
from .parameter_row import ParameterRow, integer, number, numbers, parameter_set, rows_by_name, switch, text
from .profile import ForceProfile
from .record_batch_rows import RECORD_BATCH_ROWS
from .set_point import ShrinkingOffset
from .teleoperation import TeleoperationCommandIntegrator, TeleoperationMode

#: [s] the least time between the two poses the handle's velocity is differenced over: a quarter of the haptic
#: device's 4 ms period. Two poses closer than that (a driver's duplicate, a clock step) would make a velocity of any
#: size, up to infinity at a subnormal interval, and the velocity enters Eq. 3's damping and x_d''s rate; so the
#: difference waits for the next pose far enough from the last one used.
MIN_VELOCITY_INTERVAL_S = 0.001

#: Parameters of the handle's FIC profile (Eq. 1); changing one rebuilds the attractor (phase reset).
PROFILE_PARAMETERS = ("stiffness", "saturation_error", "saturation_start", "max_force", "rate_deadband")
INTEGRATOR_PARAMETERS = ("workspace_scale", "velocity_gain", "velocity_deadband")
HOMING_PARAMETERS = ("homing_stiffness", "homing_damping", "homing_speed", "homing_tolerance")
FIXTURE_PARAMETERS = ("guidance_fixture", "guidance_point", "guidance_direction", "guidance_stiffness",
                      "guidance_damping", "guidance_max_force")
Notice = tuple[str, str]

#: The master's numeric parameters (fic_core.parameter_row rows); their values are config/master.yaml's
#: alone (one home for each value).
MASTER_NUMBERS: dict[str, ParameterRow] = rows_by_name(
    number("stiffness", 1.0, 5000.0, "K0 of the handle's FIC [N/m] (Eq. 1)"),
    number("saturation_error", 0.001, 1.0, "x_b of the handle's FIC [m]"),
    number("saturation_start", 0.0, 0.99, "xi of the handle's FIC, in [0, 1)"),
    number("max_force", 0.1, 100.0, "F_max of the handle's FIC [N] (>= xi*K0*x_b)"),
    number("rate_deadband", 0.0, 1.0, "dead-band on d|x_M|/dt for entering the convergence phase [m/s]"),
    number("haptic_gain", 0.0, 10.0, "K_H: share of the replica force rendered on the handle (Eq. 3), in [0, 1]; "
                                     "values above 1 are clamped to 1 with a warning"),
    number("max_device_force", 0.0, 1000.0, "norm limit of the device force [N] (sigma.7: ~20 N continuous); 0: no "
                                            "limit"),
    number("workspace_scale", 0.01, 100.0, "s_M: offset-mode scale"),
    number("velocity_gain", 0.0, 100.0, "k_v: velocity-mode gain [1/s]"),
    number("velocity_deadband", 0.0, 0.1, "velocity mode ignores |x_M| below this [m] so a resting hand does not "
                                          "drift"),
    number("feedback_timeout", 0.001, 60.0, "F_R older than this (receipt time) is treated as zero [s]"),
    number("pose_timeout", 0.001, 60.0, "no /haptic/pose for this long: the wrench command is zero [s]"),
    number("handle_extrapolation", 0.0, 0.05, "the longest the last handle pose is carried forward by its velocity to "
                                              "a network tick's stamp [s]; 0: sent as received (docs/CONTROL_LAWS.md)"),
    number("control_rate", 1.0, 5000.0, "/haptic/wrench_command rate [Hz]", read_only=True),
    number("network_rate", 1.0, 5000.0, "/master/pose and /master/teleop_command rate [Hz]", read_only=True),
    number("diagnostics_rate", 0.01, 100.0, "/diagnostics rate [Hz]", read_only=True),
    # The channel's master port (fic_core.channel_ports: the master node builds it, MasterStation does not read it).
    number("channel_max_damping", 0.0, 1000000.0, "bound on the TDPA damper alpha at the channel's master port [N "
                                                  "s/m]: the handle's mass times control_rate stops the handle in one "
                                                  "tick", read_only=True),
    # The operator's tools (module docstring).
    number("force_scale", 0.0, 100.0, "k_F: scale of F_R on the handle, f = FIC(-x_M) + k_F K_H F_R (1: Eq. 3 as "
                                      "written); force_scale x workspace_scale x haptic_gain <= 1, a change past it "
                                      "refused (docs/CONTROL_LAWS.md, \"Master\")"),
    number("homing_stiffness", 0.1, 1000.0, "homing: K of the approach near the centre [N/m]"),
    number("homing_damping", 0.1, 100.0, "homing: B, the damper that sets the handle's speed [N s/m] (B T / m < 2 "
                                         "at the control period T and the handle's mass m)"),
    number("homing_speed", 0.001, 1.0, "homing: the bound on the handle's speed toward the centre [m/s]"),
    number("homing_tolerance", 0.0001, 0.05, "homing: the handle is homed, and engaged, this close to the centre "
                                             "[m]"),
    number("guidance_stiffness", 0.0, 5000.0, "guidance fixture: K of the spring from x_d' to its projection on "
                                              "the fixture [N/m]"),
    number("guidance_damping", 0.0, 100.0, "guidance fixture: B on the handle's velocity across the fixture [N "
                                           "s/m]"),
    number("guidance_max_force", 0.0, 100.0, "guidance fixture: the bound on its force's norm [N]"),
    number("tools_rate", 0.1, 1000.0, "/master/operator_tools rate [Hz] (also sent at once when the engagement "
                                      "changes)", read_only=True),
)
#: The operator's tools that are not numbers.
MASTER_TOOLS: dict[str, ParameterRow] = rows_by_name(
    switch("clutch", "true: the clutch is held (indexing): the handle moves, x_d' holds still; false: engaged, "
                     "re-anchored without a jump of x_d' (button 3 on /operator/joy holds it too)"),
    switch("homing", "true: drive the handle to the centre at homing_speed, x_d' held, and engage it once homed "
                     "(at start, or now when set); it reads false again once homed"),
    text("guidance_fixture", "none, plane or line: guides x_d' onto the fixture with a bounded spring at the handle"),
    numbers("guidance_point", "a point of the fixture, in x_d' coordinates [m] (3 numbers)"),
    numbers("guidance_direction", "the plane's normal or the line's direction, in x_d' coordinates (3 numbers, not "
                                  "zero)"),
)
#: Every parameter of the master, in the order the master node declares them (config/master.yaml's keys): the
#: numbers, the mode and the frame, the operator's tools, the channel's master port and the handle FIC's exchanged
#: energy.
MASTER_PARAMETERS: dict[str, ParameterRow] = {
    **MASTER_NUMBERS,
    **rows_by_name(integer("mode", 0, 1, "teleoperation mode: 0 offset (x_d' = s_M*x_M), 1 velocity "
                                         "(x_d' += k_v*x_M*dt)"),
                   text("frame_id", "frame of /master/pose and /haptic/wrench_command", read_only=True),
                   switch("device_in_process", "the simulated haptic device runs in this process (a node group with "
                                               "its master_in_process): its pose and velocity come straight from it "
                                               "and the force command goes straight to it "
                                               "(fic_teleop_runtime.in_process_link); no DDS subscriptions of "
                                               "/haptic/pose and /haptic/twist", read_only=True)),
    **MASTER_TOOLS, **CHANNEL_PORT_SWITCHES, **CHANNEL_PORT_NUMBERS, **EXCHANGED_ENERGY_SWITCHES, **RECORD_BATCH_ROWS}
#: The rows fixed at start (rates and frames: timers and message frames are created from them; the channel port's and
#: the exchanged-energy observer's switches), read from the table, so that the station refuses what the node refuses.
READ_ONLY = tuple(name for name, row in MASTER_PARAMETERS.items() if row.read_only)
#: The master's parameters as one typed object, one field a row of MASTER_PARAMETERS (fic_core.parameter_row):
#: ``MasterParameters.from_values(values)`` checks every value and refuses a name no row has, naming the nearest.
MasterParameters = parameter_set("MasterParameters", __name__, "master", MASTER_PARAMETERS.values(),
                                 "The master's parameters (MASTER_PARAMETERS), checked, one field a row.")


class Engagement(IntEnum):
    """Whether the handle drives x_d' (values as fic_teleop_msgs/OperatorTools' ENGAGEMENT_* constants)."""

    ENGAGED = 0
    CLUTCHED = 1
    HOMING = 2


@dataclass(frozen=True)
class TeleoperationSample:
    """What a network tick sends the replica (fic_teleop_msgs/TeleoperationCommand's fields): x_d' with the mode,
    the gains and x_M it was made with, all of that tick."""

    mode: int                                 # TeleoperationMode
    haptic_gain: float                        # K_H
    workspace_scale: float                    # s_M
    velocity_gain: float                      # k_v [1/s]
    handle_position: NDArray[np.float64]      # x_M at the tick's stamp [m]
    desired_offset: NDArray[np.float64]       # x_d' [m]


#: A guidance fixture switched on, off or moved takes the sent x_d' to its new place at this speed [m/s] (the
#: replica's own resume speed): the replica's goal never jumps.
GOAL_TRANSITION_SPEED = 0.1
_NO_FORCE = np.zeros(3)   # F_R while the clutch is held, the guidance force while there is none
_NO_FORCE.setflags(write=False)


def _attractor(p: MasterParameters) -> FractalAttractor:
    return FractalAttractor(ForceProfile(p.stiffness, p.saturation_error, p.saturation_start, p.max_force), 3,
                            p.rate_deadband)


def _device_limit(value: float) -> float | None:
    return None if value == 0.0 else value


def _homing(p: MasterParameters) -> HandleHoming:
    return HandleHoming(p.homing_stiffness, p.homing_damping, p.homing_speed, p.homing_tolerance)


def _fixture(p: MasterParameters) -> GuidanceFixture | None:
    """The fixture of ``p``, or None for ``none`` (its point and direction are checked either way)."""
    kind = fixture_kind(p.guidance_fixture)
    fixture = GuidanceFixture(FixtureKind.PLANE if kind == FixtureKind.NONE else kind, p.guidance_point,
                              p.guidance_direction, stiffness=p.guidance_stiffness, damping=p.guidance_damping,
                              max_force=p.guidance_max_force)
    return None if kind == FixtureKind.NONE else fixture


def clamped_haptic_gain(value: float) -> float:
    """K_H as MasterLaw takes it: a finite value outside [0, 1] becomes the nearest bound (NaN passes on, to be
    refused by MasterLaw)."""
    return min(max(value, 0.0), 1.0) if np.isfinite(value) else value


class MasterStation:
    """Eq. 3 and the teleoperation command for the master's parameters (module docstring). ``channel_port``: the
    channel's master port, when the caller holds both ends (the in-process runner sums the channel's balance); else
    one is built from the parameters. ``parameters`` is kept as the station holds them now (the buttons, homing and
    a clamped K_H change some)."""

    def __init__(self, parameters: MasterParameters, channel_port: MasterChannelPort | None = None) -> None:
        p = self.parameters = parameters
        self.law = MasterLaw(_attractor(p), 0.0, _device_limit(p.max_device_force), p.force_scale)
        self.law.set_haptic_gain(p.haptic_gain)
        self.integrator = TeleoperationCommandIntegrator(p.workspace_scale, p.velocity_gain, p.mode,
                                                         p.velocity_deadband)
        checked_loop_gain(self.law.force_scale, self.integrator.workspace_scale, self.law.haptic_gain)
        self.homing = _homing(p)
        self.fixture = _fixture(p)
        self.clutch_held = p.clutch
        self.homing_active = p.homing
        self.guidance_force = _NO_FORCE   # the fixture's force at the last control tick (read only)
        # The sent x_d' (projected onto the fixture, if any) and what is left of a fixture change's jump.
        self.sent_offset: NDArray[np.float64] | None = None
        self._goal_transition = ShrinkingOffset()
        self.integrator.hold(self.engagement != Engagement.ENGAGED)
        self.feedback_timeout = finite_scalar("feedback_timeout", p.feedback_timeout, minimum=0.0)
        self.pose_timeout = finite_scalar("pose_timeout", p.pose_timeout, minimum=0.0)
        self.handle_extrapolation = finite_scalar("handle_extrapolation", p.handle_extrapolation, minimum=0.0)
        self._buttons = ButtonEdges()
        self.handle_position: NDArray[np.float64] | None = None   # x_M, last good
        self.handle_orientation = (0.0, 0.0, 0.0, 1.0)
        self.handle_velocity = np.zeros(3)
        self.network_handle_position: NDArray[np.float64] | None = None  # x_M at the last network tick
        self.pose_received: float | None = None
        self._twist_received: float | None = None
        self._previous_pose: tuple[float, NDArray[np.float64]] | None = None
        self._replica_force = np.zeros(3)
        self.feedback_received: float | None = None
        self.feedback_stale = False   # said once a stale period
        self._last_network_time: float | None = None
        self.wrench_count = 0
        self.saturated_count = 0
        self.law_evaluations = 0   # wrench commands that evaluated Eq. 3 (not the zero of a stale pose)
        self.channel_port = MasterChannelPort(p.channel_passivity_control, p.channel_max_damping,
                                              p.channel_energy_window) if channel_port is None else channel_port
        self.exchanged = MasterExchangedEnergy(1.0 / p.control_rate) if p.exchanged_energy_observer else None

    # --- parameters ------------------------------------------------------------------------------------------
    def configure(self, changes: Mapping[str, Any]) -> list[Notice]:
        """Apply parameter changes, all or none (FicInputError names the bad one). Names that are not the master's
        (rclpy's own, such as use_sim_time, which a node's set may carry) are not the station's to apply."""
        for name, new in changes.items():
            if name in READ_ONLY:
                raise FicInputError(f"{name} is fixed at start")
            if isinstance(new, float) and not np.isfinite(new):
                raise FicInputError(f"{name} must be finite, got {new}")
        values = self.parameters.replaced({name: new for name, new in changes.items() if name in MASTER_PARAMETERS})
        changes = {name: getattr(values, name) for name in changes if name in MASTER_PARAMETERS}   # as checked
        attractor = _attractor(values) if any(name in PROFILE_PARAMETERS for name in changes) else None
        for name in INTEGRATOR_PARAMETERS:  # checked before anything is applied
            if name in changes:
                TeleoperationCommandIntegrator(**{name: changes[name]})
        for name in ("feedback_timeout", "pose_timeout", "max_device_force", "haptic_gain", "handle_extrapolation",
                     "force_scale"):
            if name in changes:
                finite_scalar(name, changes[name], minimum=0.0)
        haptic_gain = min(changes["haptic_gain"], 1.0) if "haptic_gain" in changes else self.law.haptic_gain
        checked_loop_gain(values.force_scale, values.workspace_scale, haptic_gain)
        homing = _homing(values) if any(name in HOMING_PARAMETERS for name in changes) else None
        fixture_changed = any(name in FIXTURE_PARAMETERS for name in changes)
        fixture = _fixture(values) if fixture_changed else None
        notices: list[Notice] = []
        if attractor is not None:
            self.law = MasterLaw(attractor, self.law.haptic_gain, self.law.max_device_force, self.law.force_scale)
            notices.append(("info", "handle FIC profile changed: attractor rebuilt (phase reset)"))
        if homing is not None:
            self.homing = homing
        if fixture_changed:
            self.fixture = fixture
            self.guidance_force = _NO_FORCE
            if self.sent_offset is not None:   # the sent goal moves to its new place at a bounded speed
                self._goal_transition.start(self.sent_offset, self._goal(self.integrator.desired_offset),
                                            GOAL_TRANSITION_SPEED)
            notices.append(("info", f"guidance fixture: {values.guidance_fixture}"))
        for name, new in changes.items():
            if name == "haptic_gain":
                notices += self.set_haptic_gain(new, "parameter")
            elif name == "force_scale":
                self.law.force_scale = new
            elif name == "clutch":
                notices += self.set_clutch(new, "parameter")
            elif name == "homing":
                notices += self.start_homing() if new else self.stop_homing()
            elif name == "handle_extrapolation":
                self.handle_extrapolation = float(new)
            elif name == "max_device_force":
                self.law.max_device_force = _device_limit(new)
            elif name == "mode" and new != self.integrator.mode:
                self.integrator.set_mode(new)
                notices.append(("info", f"teleoperation mode: {self.integrator.mode.name} (parameter)"))
            elif name in INTEGRATOR_PARAMETERS:
                setattr(self.integrator, name, new)
            elif name in ("feedback_timeout", "pose_timeout"):
                setattr(self, name, float(new))
        self.parameters = dataclasses.replace(values, haptic_gain=self.law.haptic_gain, clutch=self.clutch_held,
                                              homing=self.homing_active)
        return notices

    def set_haptic_gain(self, value: float, source: str) -> list[Notice]:
        """K_H, clamped to [0, 1] and to the loop-gain bound's ceiling (a notice says so); FicInputError for
        NaN/Inf."""
        ceiling = haptic_gain_ceiling(self.law.force_scale, self.integrator.workspace_scale)
        requested = finite_scalar("haptic_gain", value)
        self.law.set_haptic_gain(min(requested, ceiling))
        self.parameters = dataclasses.replace(self.parameters, haptic_gain=self.law.haptic_gain)
        if self.law.haptic_gain == requested:
            return []
        why = ": force_scale x workspace_scale x haptic_gain may not exceed 1" if requested > ceiling < 1.0 else ""
        return [("warning", f"haptic_gain {value} from {source} clamped to {self.law.haptic_gain}{why}")]

    # --- the clutch and homing ----------------------------------------------------------------------------------
    @property
    def engagement(self) -> Engagement:
        """HOMING while the handle is driven home, else CLUTCHED while the clutch is held, else ENGAGED."""
        if self.homing_active:
            return Engagement.HOMING
        return Engagement.CLUTCHED if self.clutch_held else Engagement.ENGAGED

    def _engage_if_free(self) -> None:
        self.integrator.hold(self.engagement != Engagement.ENGAGED)
        self.parameters = dataclasses.replace(self.parameters, clutch=self.clutch_held, homing=self.homing_active)

    def set_clutch(self, held: bool, source: str) -> list[Notice]:
        """Hold the clutch (x_d' holds still) or release it (engaged again, re-anchored)."""
        if bool(held) == self.clutch_held:
            return []
        self.clutch_held = bool(held)
        self._engage_if_free()
        if held:
            return [("info", f"clutch held ({source}): x_d' holds still while the handle moves")]
        after = "engaged, x_d' continues from where it stood" if self.engagement == Engagement.ENGAGED else \
            "homing goes on"
        return [("info", f"clutch released ({source}): {after}")]

    def start_homing(self) -> list[Notice]:
        if self.homing_active:
            return []
        self.homing_active = True
        self._engage_if_free()
        return [("info", f"homing: driving the handle to the centre at {self.homing.speed:g} m/s at most; x_d' "
                         f"holds still until it is within {self.homing.tolerance * 1000:g} mm")]

    def stop_homing(self) -> list[Notice]:
        """End homing before the handle is home (the parameter set false): engaged where the handle is."""
        if not self.homing_active:
            return []
        self._finish_homing()
        return [("warning", "homing stopped before the handle was home: engaged where it is")]

    def _finish_homing(self) -> None:
        self.homing_active = False
        self.law.reset()   # the handle's FIC was not evaluated while homing: it starts afresh at the centre
        self._engage_if_free()

    # --- inputs ----------------------------------------------------------------------------------------------
    def add_pose(self, position: ArrayLike, quaternion_xyzw: Sequence[float], now: float) -> None:
        """x_M and the handle's orientation; the velocity by differencing while no twist is fresh."""
        position = finite_array("handle_position", position, (3,)).copy()
        quaternion = tuple(float(v) for v in finite_array("handle_orientation", quaternion_xyzw, (4,)))
        previous = self._previous_pose
        # A fresh twist is the velocity; a clock that went back starts the differences from here.
        if previous is None or self._twist_fresh(now) or now < previous[0]:
            self._previous_pose = (now, position)
        elif now - previous[0] >= MIN_VELOCITY_INTERVAL_S:
            self.handle_velocity = (position - previous[1]) / (now - previous[0])
            self._previous_pose = (now, position)
        else:   # too close: the newer position, at the time of the last difference (a burst's newest pose)
            self._previous_pose = (previous[0], position)
        self.handle_position = position
        self.handle_orientation = quaternion
        self.pose_received = now

    def _twist_fresh(self, now: float) -> bool:
        return self._twist_received is not None and now - self._twist_received <= self.pose_timeout

    def add_twist(self, velocity: ArrayLike, now: float) -> None:
        """The device's own handle velocity (preferred to differences while fresh)."""
        self.handle_velocity = finite_array("handle_velocity", velocity, (3,)).copy()
        self._twist_received = now

    def add_feedback(self, force: ArrayLike, now: float, replica_input_energy: float | None = None) -> list[Notice]:
        """F_R through the channel, for Eq. 3 and the channel's master port, with the replica port's E_in when it
        travels with F_R (in one process; on the graph it comes on its own: ``replica_port_energy``)."""
        notices = self._keep_feedback(force, now)
        self.channel_port.receive_feedback(force, now)
        if replica_input_energy is not None:
            self.channel_port.receive_energy(replica_input_energy)
        return notices

    def replica_port_energy(self, input_energy: float) -> None:
        """The replica port's E_in, as the channel delivered it."""
        self.channel_port.receive_energy(input_energy)

    def _keep_feedback(self, force: ArrayLike, now: float) -> list[Notice]:
        """The F_R Eq. 3 renders (the received one, or the channel port's damped one)."""
        self._replica_force = finite_array("replica_force", force, (3,)).copy()
        self.feedback_received = now
        if self.feedback_stale:
            self.feedback_stale = False
            return [("info", "/master/feedback_wrench is fresh again")]
        return []

    def press(self, buttons: Sequence[int]) -> tuple[list[Notice], tuple[str, ...]]:
        """Button states of an operator message: (notices, the parameters they changed, as ``parameters`` now
        holds them)."""
        pressed, released = self._buttons.changes(buttons)
        notices: list[Notice] = []
        changed: list[str] = []
        if OperatorButton.TOGGLE_MODE in pressed:
            mode = self.integrator.toggle_mode()
            self.parameters = dataclasses.replace(self.parameters, mode=int(mode))
            notices.append(("info", f"teleoperation mode: {mode.name} (button)"))
            changed.append("mode")
        step = HAPTIC_GAIN_STEP * ((OperatorButton.HAPTIC_GAIN_UP in pressed) -
                                   (OperatorButton.HAPTIC_GAIN_DOWN in pressed))
        if step:
            notices += self.set_haptic_gain(round(self.law.haptic_gain + step, 6), "button")
            notices.append(("info", f"haptic gain K_H = {self.law.haptic_gain:.2f} (button)"))
            changed.append("haptic_gain")
        if (OperatorButton.CLUTCH in pressed or OperatorButton.CLUTCH in released) and \
                (OperatorButton.CLUTCH in pressed) != self.clutch_held:
            notices += self.set_clutch(OperatorButton.CLUTCH in pressed, "button")
            changed.append("clutch")
        return notices, tuple(changed)

    # --- outputs ---------------------------------------------------------------------------------------------
    def update(self, now: float, dt: float) -> tuple[NDArray[np.float64] | None, list[Notice]]:
        """One control tick at ``now``, ``dt`` [s] after the last, in its order (module docstring): the channel's
        master port, Eq. 3, the handle FIC's exchanged energy. Returns what ``force`` returns: the device force
        (None before the first pose) and the notices."""
        damped = self.channel_port.tick(now, dt, self._offset_rate(), self.feedback_timeout)
        if damped is not None:
            self._keep_feedback(*damped)   # fresh already: nothing to say
        force, notices = self.force(now)
        if self.exchanged is not None:
            self.exchanged.observe(self.law_evaluations, self.law.attractor)
        return force, notices

    def _offset_rate(self) -> NDArray[np.float64]:
        """The rate of x_d' the channel's master port books: zero while x_d' stands still (the clutch held, homing,
        no handle yet)."""
        integrator = self.integrator
        if self.handle_position is None or integrator.held:
            return np.zeros(3)
        return port_velocity(integrator.mode, integrator.workspace_scale, integrator.velocity_gain,
                             self.handle_position, self.handle_velocity)

    def pose_stale(self, now: float) -> bool:
        return self.pose_received is None or now - self.pose_received > self.pose_timeout

    def feedback_force(self, now: float) -> tuple[NDArray[np.float64], list[Notice]]:
        """F_R, or zero (said once per stale period) if older than feedback_timeout or never received."""
        if self.feedback_received is not None and now - self.feedback_received <= self.feedback_timeout:
            return self._replica_force, []
        notices: list[Notice] = []
        if not self.feedback_stale:
            age = "never received" if self.feedback_received is None else \
                f"{now - self.feedback_received:.2f} s old"
            notices.append(("warning", f"/master/feedback_wrench is stale ({age}): rendering F_R = 0"))
            self.feedback_stale = True
        return np.zeros(3), notices

    def force(self, now: float) -> tuple[NDArray[np.float64] | None, list[Notice]]:
        """The device force f at ``now`` (None before the first pose; zero while the pose is stale): Eq. 3 with the
        guidance fixture's force while engaged, the handle's own FIC alone while the clutch is held, the homing
        attractor's force while homing (which engages the handle once it is home). Eq. 3 alone: a control tick is
        ``update``, which books the channel's port before it and the exchanged energy after it."""
        position = self.handle_position
        if position is None:
            return None, []
        notices: list[Notice] = []
        if self.pose_stale(now):
            force = np.zeros(3)
            notices.append(("repeated_warning", "/haptic/pose is stale: commanding zero force"))
        elif self.homing_active:
            force = self.homing.force(position, self.handle_velocity)
            if self.law.max_device_force is not None:
                bounded = norm_bounded(force, self.law.max_device_force)
                self.saturated_count += int(bounded is not force)
                force = bounded
            if self.homing.homed(position):
                self._finish_homing()
                after = "engaged" if self.engagement == Engagement.ENGAGED else "the clutch is still held"
                notices.append(("info", f"handle homed ({np.linalg.norm(position) * 1000:.1f} mm from the centre): "
                                        f"{after}"))
        else:
            feedback, notices = self.feedback_force(now)
            guidance = None
            if self.clutch_held:
                feedback = _NO_FORCE   # the handle no longer drives x_d': F_R does not answer its motion
            elif self.fixture is not None:
                guidance = self.fixture.force(self.integrator.goal_at(position), self.handle_velocity)
            self.guidance_force = _NO_FORCE if guidance is None else guidance
            force = self.law.force(position, self.handle_velocity, feedback, guidance)
            self.saturated_count += int(self.law.device_force_saturated)
            self.law_evaluations += 1
        self.wrench_count += 1
        return force, notices

    def handle_at(self, now: float) -> NDArray[np.float64] | None:
        """x_M at ``now``: the last pose carried forward by the handle velocity over its age, if that age is at
        most ``handle_extrapolation`` (0: never; an older pose is sent as it is: a stale pose is the device's
        silence, not a motion). Why: a network tick is stamped ``now`` but the last pose is up to one device
        period older (4 ms at 250 Hz, at a random phase: the two timers are not aligned), so x_d' lags its own
        stamp by 0-4 ms of handle motion, which the delay carries to the replica as an error no controller
        can remove (docs/CONTROL_LAWS.md, "The handle at the network tick")."""
        position = self.handle_position
        if position is None or self.pose_received is None:
            return position
        age = now - self.pose_received
        if not 0.0 < age <= self.handle_extrapolation:
            return position
        return position + age * self.handle_velocity

    def desired_offset(self, now: float) -> NDArray[np.float64] | None:
        """x_d' at a network tick at ``now`` from x_M at ``now`` (``handle_at``; None before the first pose).
        The x_M used is kept as ``network_handle_position``: the command carries it with the same stamp."""
        handle = self.handle_at(now)
        if handle is None:
            return None
        dt = 0.0 if self._last_network_time is None else max(now - self._last_network_time, 0.0)
        self._last_network_time = now
        self.network_handle_position = handle
        self.sent_offset = self._goal_transition.apply(self._goal(self.integrator.update(handle, dt)), dt)
        return self.sent_offset

    @property
    def mode(self) -> TeleoperationMode:
        return self.integrator.mode

    @property
    def integrated_offset(self) -> NDArray[np.float64]:
        """x_d' as the teleoperation integrator holds it (before a guidance fixture's projection)."""
        return self.integrator.desired_offset

    def teleoperation_command(self, now: float) -> TeleoperationSample | None:
        """The network tick at ``now``: x_d' (``desired_offset``) with what travels with it (None before the first
        pose)."""
        offset = self.desired_offset(now)
        if offset is None:
            return None
        integrator = self.integrator
        return TeleoperationSample(int(integrator.mode), float(self.law.haptic_gain),
                                   float(integrator.workspace_scale), float(integrator.velocity_gain),
                                   self.network_handle_position.copy(), offset)

    def _goal(self, offset: NDArray[np.float64]) -> NDArray[np.float64]:
        """The goal sent for the handle's x_d': its projection onto the guidance fixture, if there is one."""
        return offset if self.fixture is None else self.fixture.projection(offset)

    def loop_gain(self) -> float:
        """G = k_F s_M K_H (at most 1)."""
        return loop_gain(self.law.force_scale, self.integrator.workspace_scale, self.law.haptic_gain)

    def fixture_goal(self) -> NDArray[np.float64] | None:
        """x_d' projected on the guidance fixture (None without one)."""
        return None if self.fixture is None else self.fixture.projection(self.integrator.desired_offset)

    def diagnostics(self, now: float) -> tuple[list[str], dict[str, str]]:
        """(problems, values) for a diagnostics message."""
        problems = []
        if self.handle_position is None:
            problems.append("no /haptic/pose yet")
        elif self.pose_stale(now):
            problems.append("/haptic/pose stale")
        if self.feedback_stale:
            problems.append("/master/feedback_wrench stale (F_R = 0)")
        feedback_age = np.inf if self.feedback_received is None else now - self.feedback_received
        return problems, {
            "mode": self.integrator.mode.name, "haptic_gain": f"{self.law.haptic_gain:.3f}",
            "engagement": self.engagement.name, "force_scale": f"{self.law.force_scale:.3f}",
            "loop_gain": f"{self.loop_gain():.3f}", "guidance_fixture": str(self.parameters.guidance_fixture),
            "feedback_age_s": f"{feedback_age:.3f}",
            "phase": " ".join(str(int(p)) for p in self.law.attractor.phase),
            "wrench_commands": str(self.wrench_count), "device_force_saturated_ticks": str(self.saturated_count),
            "desired_offset": " ".join(f"{v:.4f}" for v in self.integrator.desired_offset)}


__all__ = ["Engagement", "MASTER_PARAMETERS", "MasterParameters", "MasterStation", "PROFILE_PARAMETERS", "READ_ONLY",
           "TeleoperationMode", "TeleoperationSample"]
