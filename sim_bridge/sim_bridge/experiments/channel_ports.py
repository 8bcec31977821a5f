"""The delayed channel's two ports in the in-process runner: time-domain passivity observers, and for the
``linear_tdpa`` baseline the passivity controllers (fic_core.channel_passivity_observer, passivity_controller).

Master port: the offset x_d' the master sends against the replica force F_R it receives; power into the channel
-F_R . v with v the rate of x_d' (offset mode: s_M times the handle's velocity). Replica port: x_d' as delivered
against the F_R the replica sends back; power into the channel F_R . v. These are the ports and signs of the
report's ``channel_energy_generated_j`` (sim_bridge.report.metrics), booked here tick by tick. Each side's E_in
travels to the other side with that side's messages (the caller puts ``master_input_energy`` into the forward
payload and ``replica_input_energy`` into the backward one), so the observers know only what the channel let
through, one delay late, as on two machines.

With ``control`` the master side renders F_R - alpha v (the variable damper) and the replica side tracks the
offset with its rate corrected by beta F_R; without, the same observers only watch.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.passivity_controller import ForcePortPassivityController, MotionPortPassivityController
from fic_core.teleoperation import TeleoperationMode

#: The replica side's offset correction per delivery [m]: 1 mm at the channel's 250 Hz deliveries is 0.25 m/s,
#: a quarter of the input authority's 1 m/s bound on x_d''s speed, so a correction never looks like a jump.
MAX_OFFSET_CORRECTION_M = 0.001


class ChannelPorts:
    """Both ports' observers and, with ``control``, their passivity controllers (module docstring)."""

    def __init__(self, control: bool, handle_mass: float, master_period: float) -> None:
        self.control = bool(control)
        # The damper stops the handle in one master tick at most (alpha dt / m = 1): a larger alpha, held over the
        # device's substeps, would overshoot and make the damper itself active.
        self.master = ForcePortPassivityController(handle_mass / master_period, enabled=self.control)
        self.replica = MotionPortPassivityController(MAX_OFFSET_CORRECTION_M, enabled=self.control)
        self._last_delivery: float | None = None

    @property
    def master_input_energy(self) -> float:
        return self.master.observer.input_energy

    @property
    def replica_input_energy(self) -> float:
        return self.replica.observer.input_energy

    @property
    def generated_energy(self) -> float:
        """What left the channel at both ports minus what entered [J] (the report's figure; only a simulation
        that holds both sides can sum it)."""
        master, replica = self.master.observer, self.replica.observer
        return master.output_energy + replica.output_energy - master.input_energy - replica.input_energy

    @staticmethod
    def port_velocity(mode: TeleoperationMode, workspace_scale: float, velocity_gain: float,
                      handle_position: ArrayLike, handle_velocity: ArrayLike) -> NDArray[np.float64]:
        """The rate of x_d': s_M v_M in offset mode, k_v x_M in velocity mode (its dead-band left out)."""
        if mode == TeleoperationMode.OFFSET:
            return workspace_scale * np.asarray(handle_velocity, dtype=float)
        return velocity_gain * np.asarray(handle_position, dtype=float)

    def master_tick(self, feedback: ArrayLike, velocity: ArrayLike, dt: float) -> NDArray[np.float64]:
        """The force the master renders for the received ``feedback`` F_R (zero when stale) and the port velocity."""
        return self.master.step(feedback, velocity, dt)

    def replica_delivery(self, offset: ArrayLike, force_sent: ArrayLike, now: float) -> NDArray[np.float64]:
        """The offset the replica tracks for a delivered ``offset``; ``force_sent`` is the last F_R sent back."""
        dt = 0.0 if self._last_delivery is None else max(now - self._last_delivery, 0.0)
        self._last_delivery = now
        return self.replica.step(offset, force_sent, dt)
