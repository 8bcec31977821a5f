"""The master side's logic (paper Eq. 3 and Sec. II-C) around fic_core.MasterLaw: what the master node runs and
the in-process runner steps.

    handle pose x_M, twist --> the handle velocity (the device's twist while fresh, else differences of poses)
    F_R (through the channel) --> feedback freshness (older than feedback_timeout: rendered as zero, said once)
    --> MasterLaw f = FIC(-x_M) + K_H F_R  (zero while the pose is older than pose_timeout)
    x_M --> TeleoperationCommandIntegrator --> x_d' (offset or velocity mode, at the network rate)
    operator buttons (rising edges, fic_core.operator_buttons) --> mode toggle, K_H steps

``configure`` is the parameter dispatch: a change of the handle's profile rebuilds its attractor (phase reset),
the others are applied in place; every value is checked before any is applied. Notices (what the caller should
log) come back as (level, text), level one of info, warning and repeated_warning (one said at every tick while
its cause lasts: to be throttled).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .attractor import FractalAttractor
from .errors import FicInputError, finite_array, finite_scalar
from .master import MasterLaw
from .parameter_row import ParameterRow, number, rows_by_name
from .operator_buttons import HAPTIC_GAIN_STEP, ButtonEdges, OperatorButton
from .profile import ForceProfile
from .teleoperation import TeleoperationCommandIntegrator, TeleoperationMode

#: Parameters of the handle's FIC profile (Eq. 1); changing one rebuilds the attractor (phase reset).
PROFILE_PARAMETERS = ("stiffness", "saturation_error", "saturation_start", "max_force", "rate_deadband")
INTEGRATOR_PARAMETERS = ("workspace_scale", "velocity_gain", "velocity_deadband")
#: Rates and frames are fixed at start (timers and message frames are created from them).
READ_ONLY = ("control_rate", "network_rate", "diagnostics_rate", "frame_id", "channel_max_damping")
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
)



def _checked(values: Mapping[str, Any]) -> dict[str, Any]:
    """The numbers of ``values`` that are rows of MASTER_NUMBERS, each checked against its row (its range)."""
    return {name: MASTER_NUMBERS[name].checked(value) for name, value in values.items() if name in MASTER_NUMBERS}


def _attractor(values: Mapping[str, Any]) -> FractalAttractor:
    profile = ForceProfile(values["stiffness"], values["saturation_error"], values["saturation_start"],
                           values["max_force"])
    return FractalAttractor(profile, 3, values["rate_deadband"])


def _device_limit(value: float) -> float | None:
    return None if value == 0.0 else value


def clamped_haptic_gain(value: float) -> float:
    """K_H as MasterLaw takes it: a finite value outside [0, 1] becomes the nearest bound (NaN passes on, to be
    refused by MasterLaw)."""
    return min(max(value, 0.0), 1.0) if np.isfinite(value) else value


class MasterStation:
    """Eq. 3 and the teleoperation command for a parameter mapping (the master's parameters; module docstring)."""

    def __init__(self, values: Mapping[str, Any]) -> None:
        values = {**values, **_checked(values)}
        self.parameters = dict(values)
        self.law = MasterLaw(_attractor(values), 0.0, _device_limit(values["max_device_force"]))
        self.law.set_haptic_gain(values["haptic_gain"])
        self.integrator = TeleoperationCommandIntegrator(values["workspace_scale"], values["velocity_gain"],
                                                         values["mode"], values["velocity_deadband"])
        self.feedback_timeout = finite_scalar("feedback_timeout", values["feedback_timeout"], minimum=0.0)
        self.pose_timeout = finite_scalar("pose_timeout", values["pose_timeout"], minimum=0.0)
        self.handle_extrapolation = finite_scalar("handle_extrapolation", values["handle_extrapolation"], minimum=0.0)
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

    # --- parameters ------------------------------------------------------------------------------------------
    def configure(self, changes: Mapping[str, Any]) -> list[Notice]:
        """Apply parameter changes, all or none (FicInputError names the bad one)."""
        for name, new in changes.items():
            if name in READ_ONLY:
                raise FicInputError(f"{name} is fixed at start")
            if isinstance(new, float) and not np.isfinite(new):
                raise FicInputError(f"{name} must be finite, got {new}")
        changes = {**changes, **_checked(changes)}
        values = {**self.parameters, **changes}
        attractor = _attractor(values) if any(name in PROFILE_PARAMETERS for name in changes) else None
        for name in INTEGRATOR_PARAMETERS:  # checked before anything is applied
            if name in changes:
                TeleoperationCommandIntegrator(**{name: changes[name]})
        for name in ("feedback_timeout", "pose_timeout", "max_device_force", "haptic_gain", "handle_extrapolation"):
            if name in changes:
                finite_scalar(name, changes[name], minimum=0.0)
        notices: list[Notice] = []
        if attractor is not None:
            self.law = MasterLaw(attractor, self.law.haptic_gain, self.law.max_device_force)
            notices.append(("info", "handle FIC profile changed: attractor rebuilt (phase reset)"))
        for name, new in changes.items():
            if name == "haptic_gain":
                notices += self.set_haptic_gain(new, "parameter")
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
        self.parameters = values
        return notices

    def set_haptic_gain(self, value: float, source: str) -> list[Notice]:
        """K_H, clamped to [0, 1] (a notice says so); FicInputError for NaN/Inf."""
        if self.law.set_haptic_gain(value):
            return [("warning", f"haptic_gain {value} from {source} clamped to {self.law.haptic_gain}")]
        return []

    # --- inputs ----------------------------------------------------------------------------------------------
    def add_pose(self, position: ArrayLike, quaternion_xyzw: Sequence[float], now: float) -> None:
        """x_M and the handle's orientation; the velocity by differencing while no twist is fresh."""
        position = finite_array("handle_position", position, (3,)).copy()
        quaternion = tuple(float(v) for v in finite_array("handle_orientation", quaternion_xyzw, (4,)))
        if self._previous_pose is not None and not self._twist_fresh(now):
            previous_time, previous_position = self._previous_pose
            if now > previous_time:
                self.handle_velocity = (position - previous_position) / (now - previous_time)
        self._previous_pose = (now, position)
        self.handle_position = position
        self.handle_orientation = quaternion
        self.pose_received = now

    def _twist_fresh(self, now: float) -> bool:
        return self._twist_received is not None and now - self._twist_received <= self.pose_timeout

    def add_twist(self, velocity: ArrayLike, now: float) -> None:
        """The device's own handle velocity (preferred to differences while fresh)."""
        self.handle_velocity = finite_array("handle_velocity", velocity, (3,)).copy()
        self._twist_received = now

    def add_feedback(self, force: ArrayLike, now: float) -> list[Notice]:
        """F_R through the channel."""
        self._replica_force = finite_array("replica_force", force, (3,)).copy()
        self.feedback_received = now
        if self.feedback_stale:
            self.feedback_stale = False
            return [("info", "/master/feedback_wrench is fresh again")]
        return []

    def press(self, buttons: Sequence[int]) -> tuple[list[Notice], bool, bool]:
        """Button states of an operator message: (notices, mode changed, K_H changed)."""
        pressed = self._buttons.pressed(buttons)
        notices: list[Notice] = []
        mode_changed = OperatorButton.TOGGLE_MODE in pressed
        if mode_changed:
            mode = self.integrator.toggle_mode()
            notices.append(("info", f"teleoperation mode: {mode.name} (button)"))
        step = HAPTIC_GAIN_STEP * ((OperatorButton.HAPTIC_GAIN_UP in pressed) -
                                   (OperatorButton.HAPTIC_GAIN_DOWN in pressed))
        if step:
            notices += self.set_haptic_gain(round(self.law.haptic_gain + step, 6), "button")
            notices.append(("info", f"haptic gain K_H = {self.law.haptic_gain:.2f} (button)"))
        if mode_changed:
            self.parameters["mode"] = int(self.integrator.mode)
        return notices, mode_changed, bool(step)

    # --- outputs ---------------------------------------------------------------------------------------------
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
        """The device force f of Eq. 3 at ``now`` (None before the first pose; zero while the pose is stale)."""
        if self.handle_position is None:
            return None, []
        notices: list[Notice] = []
        if self.pose_stale(now):
            force = np.zeros(3)
            notices.append(("repeated_warning", "/haptic/pose is stale: commanding zero force"))
        else:
            feedback, notices = self.feedback_force(now)
            force = self.law.force(self.handle_position, self.handle_velocity, feedback)
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
        return self.integrator.update(handle, dt)

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
            "feedback_age_s": f"{feedback_age:.3f}",
            "phase": " ".join(str(int(p)) for p in self.law.attractor.phase),
            "wrench_commands": str(self.wrench_count), "device_force_saturated_ticks": str(self.saturated_count),
            "desired_offset": " ".join(f"{v:.4f}" for v in self.integrator.desired_offset)}


__all__ = ["MasterStation", "PROFILE_PARAMETERS", "READ_ONLY", "TeleoperationMode"]
