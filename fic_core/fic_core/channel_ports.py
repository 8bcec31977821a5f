"""The delayed channel's two ports, each at its end of the link: time-domain passivity observers and, with
``control`` (TDPA), their passivity controllers (fic_core.channel_passivity_observer, passivity_controller).
Each side's station holds its half (fic_core.master_station, fic_core.replica_station), built from its parameters; the
in-process runner builds both (``ChannelPorts``) and hands each station its own, to sum the channel's balance.

Where each port's power is measurable: at the master, the rate v of the offset x_d' the master sends (offset mode:
s_M times the handle's velocity, 250 Hz; velocity mode: k_v x_M) against the replica force F_R it receives;
power into the channel P_M = -F_R . v, booked at every master control tick. At the replica, the rate of x_d' as
delivered against the F_R the replica last sent back; P_R = F_R . v, booked at every delivery. These are the
ports and signs of the report's ``channel_energy_generated_j`` (fic_teleop_tools.report.metrics). Each side's E_in
travels to the other side with that side's messages, so each observer knows only what the channel let through,
one delay late, as on two machines.

Per direction: the forward link (x_d', master -> replica) lets out at the replica port what entered at the master
port, so the energy it generated is E_out,R - E_in,M = -W_R, booked at the replica; the backward link (F_R) likewise
-W_M at the master. Both are upper bounds while energy is in flight (E_in of the other side is one delay old).
Each half also gives that figure's rate over a sliding window (fic_core.windowed_rate).

With ``control`` the master side renders F_R - alpha v (the variable damper) and the replica side tracks the
offset with its rate corrected by beta F_R; without, the same observers only watch.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .channel_passivity_observer import ChannelPortObserver
from .errors import finite_array, finite_scalar
from .parameter_row import ParameterRow, number, rows_by_name, switch
from .passivity_controller import ForcePortPassivityController, MotionPortPassivityController
from .teleoperation import TeleoperationMode
from .windowed_rate import WindowedRate

#: The replica side's offset correction per delivery [m]: 1 mm at the channel's 250 Hz deliveries is 0.25 m/s,
#: a quarter of the input authority's 1 m/s bound on x_d''s speed, so a correction never looks like a jump.
MAX_OFFSET_CORRECTION_M = 0.001

#: Parameters the master and the replica node both declare, fixed at start; the master's damping bound is one of the
#: master's own (fic_core.master_station).
CHANNEL_PORT_SWITCHES: dict[str, ParameterRow] = rows_by_name(
    switch("channel_passivity_control", "TDPA: the channel port's passivity controller acts (true) or its "
                                        "time-domain passivity observer only watches (false)", read_only=True),
)
CHANNEL_PORT_NUMBERS: dict[str, ParameterRow] = rows_by_name(
    number("channel_energy_window", 0.01, 600.0, "sliding window of the channel port's generated-energy rate [s]",
           read_only=True),
)


def port_velocity(mode: TeleoperationMode, workspace_scale: float, velocity_gain: float,
                  handle_position: ArrayLike, handle_velocity: ArrayLike) -> NDArray[np.float64]:
    """The rate of x_d': s_M v_M in offset mode, k_v x_M in velocity mode (its dead-band left out)."""
    if mode == TeleoperationMode.OFFSET:
        return workspace_scale * np.asarray(handle_velocity, dtype=float)
    return velocity_gain * np.asarray(handle_position, dtype=float)


class _ChannelPort:
    """What both ends share: a passivity controller (its observer inside), the windowed rate of what this end
    booked as generated, and the observer's figures for /diagnostics."""

    def __init__(self, controller: ForcePortPassivityController | MotionPortPassivityController,
                 window: float) -> None:
        self.controller = controller
        self.generated_rate = WindowedRate(window)

    @property
    def control(self) -> bool:
        return self.controller.enabled

    @property
    def observer(self) -> ChannelPortObserver:
        return self.controller.observer

    @property
    def input_energy(self) -> float:
        """E_in of this port [J]: what this end sends on to the other (x_d' at the master, F_R at the replica)."""
        return self.observer.input_energy

    @property
    def generated_energy(self) -> float:
        """What the link arriving here let out beyond what the other end put in, as known here [J]: -W."""
        return -self.observer.energy

    def receive_energy(self, other_input_energy: float) -> None:
        """E_in of the other end's port, as the channel delivered it."""
        self.observer.receive(other_input_energy)

    def _observer_values(self) -> dict[str, float]:
        observer = self.observer
        return {"input_energy_j": observer.input_energy, "output_energy_j": observer.output_energy,
                "received_input_energy_j": observer.received_input_energy, "observer_energy_j": observer.energy,
                "observer_energy_min_j": observer.min_energy, "negative_ticks": float(observer.negative_ticks),
                "ticks": float(observer.ticks), "generated_j": self.generated_energy,
                "generated_rate_w": self.generated_rate.rate, "passivity_control": float(self.control)}


class MasterChannelPort(_ChannelPort):
    """The master's end: F_R received, x_d''s rate, the variable damper (module docstring). Its generated energy
    is the backward link's (F_R)."""

    def __init__(self, control: bool, max_damping: float, window: float = 1.0) -> None:
        # The damper stops the handle in one master tick at most (alpha dt / m = 1, the caller's max_damping): a
        # larger alpha, held over the device's substeps, would overshoot and make the damper itself active.
        super().__init__(ForcePortPassivityController(max_damping, enabled=control), window)
        self._feedback = np.zeros(3)
        self._feedback_received: float | None = None

    def receive_feedback(self, force: ArrayLike, now: float) -> None:
        """F_R as the channel delivered it (kept as received: the damper acts on it afresh at every tick)."""
        self._feedback = finite_array("replica_force", force, (3,)).copy()
        self._feedback_received = finite_scalar("now", now)

    def tick(self, now: float, dt: float, velocity: NDArray[np.float64],
             feedback_timeout: float) -> tuple[NDArray[np.float64], float] | None:
        """Book one master control tick of ``dt`` [s] before Eq. 3 is evaluated, ``velocity`` being the rate of
        x_d' (``port_velocity``; zero while x_d' stands still). A F_R older than ``feedback_timeout`` is booked as
        zero, as Eq. 3 renders it. Returns, with ``control`` and a fresh F_R, the damped F_R (F_R - alpha v) and
        when F_R was received, for Eq. 3 to render instead of the received one; else None."""
        fresh = self._feedback_received is not None and now - self._feedback_received <= feedback_timeout
        rendered = self.controller.step(self._feedback if fresh else np.zeros(3), velocity, dt)
        self.generated_rate.add(now, self.generated_energy)
        return (rendered, self._feedback_received) if self.control and fresh else None

    def diagnostics(self) -> dict[str, float]:
        return {**self._observer_values(), "damping_n_s_per_m": self.controller.damping}


class ReplicaChannelPort(_ChannelPort):
    """The replica's end: x_d' delivered, F_R sent back, the offset's rate correction (module docstring). Its
    generated energy is the forward link's (x_d')."""

    def __init__(self, control: bool, window: float = 1.0) -> None:
        super().__init__(MotionPortPassivityController(MAX_OFFSET_CORRECTION_M, enabled=control), window)
        self.force_sent = np.zeros(3)
        self._last_delivery: float | None = None

    @property
    def drift(self) -> NDArray[np.float64]:
        """Delivered minus received offset [m] (the motion controller's corrections, summed)."""
        return self.controller.drift

    def sent(self, force: ArrayLike) -> float:
        """F_R as sent back to the master; returns this port's E_in, to travel with it."""
        self.force_sent = finite_array("replica_force", force, (3,)).copy()
        return self.input_energy

    def delivery(self, offset: ArrayLike, now: float) -> NDArray[np.float64]:
        """The offset the replica tracks for a delivered ``offset`` x_d' at ``now`` (booked against the last F_R
        sent); without ``control`` the delivered one."""
        dt = 0.0 if self._last_delivery is None else max(now - self._last_delivery, 0.0)
        self._last_delivery = now
        tracked = self.controller.step(offset, self.force_sent, dt)
        self.generated_rate.add(now, self.generated_energy)
        return tracked

    def diagnostics(self) -> dict[str, float]:
        drift = self.drift
        return {**self._observer_values(), "gain_m_per_n_s": self.controller.gain,
                "offset_drift_m": float(np.linalg.norm(drift)) if drift.size else 0.0}


class ChannelPorts:
    """Both ends in one process (the in-process runner), where the channel's whole balance can be summed."""

    def __init__(self, control: bool, max_damping: float, window: float = 1.0) -> None:
        self.master = MasterChannelPort(control, max_damping, window)
        self.replica = ReplicaChannelPort(control, window)

    @property
    def generated_energy(self) -> float:
        """What left the channel at both ports minus what entered [J] (the report's figure; only a process that
        holds both sides can sum it without the delay's lag)."""
        master, replica = self.master.observer, self.replica.observer
        return master.output_energy + replica.output_energy - master.input_energy - replica.input_energy
