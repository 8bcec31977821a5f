"""The exchanged-energy observer (fic_core/exchanged_energy_observer.py) at the two FIC ports a run has: the
replica's Cartesian FIC and the master's handle FIC, fed tick by tick from what each side measures.

Replica: the effort is the FIC wrench of the tick, FIC(x~_R) (6: force, moment; base frame), held until the next
tick; the port coordinate is the error x_d - x_R for translation and, for rotation, the running sum of the measured
increments log3(R_d,k R_d,k-1^T) - log3(R_k R_k-1^T) (target minus robot), as the observer's docstring asks; the
storage is AttractorStorage's quadrature of the translational attractor's declared state plus that of the angle's
one-axis attractor. Why the wrench and not the joint torque after the slew and the QP: the storage is a function of
the task-space error, and a joint torque has no storage of its own to be judged against; what the slew and the QP
change is what reaches the arm, outside this port (docs/CONTROL_LAWS.md).

Master: the effort is the handle FIC's share of the force sent to the device, FIC(-x_M) (the K_H F_R share is the
channel's energy, watched at the channel's master port, fic_core.channel_ports); the coordinate is the error
-x_M at the tick's measured handle position; the storage the handle attractor's by the same quadrature.

Only the FIC has this storage: with a linear law, or before the first tick, nothing is booked. A rebuilt attractor
(a parameter change) starts a new run of the observer.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin

from .attractor import FractalAttractor
from .attractor_storage import AttractorStorage
from .exchanged_energy_observer import DEFAULT_TOLERANCE_J, ExchangedEnergyObserver
from .parameter_row import ParameterRow, rows_by_name, switch
from .pose_attractor import PoseAttractor, PoseAttractorSnapshot
from .replica import ReplicaCommand

#: The switch both nodes declare, fixed at start.
EXCHANGED_ENERGY_SWITCHES: dict[str, ParameterRow] = rows_by_name(
    switch("exchanged_energy_observer", "book the FIC port's held effort times its measured displacement against "
                                        "the attractor's storage (fic_core.exchanged_energy_ports) and publish it "
                                        "on /diagnostics", read_only=True),
)


class ReplicaExchangedEnergy:
    """The replica FIC's port under the exchanged-energy observer (module docstring)."""

    def __init__(self, period_s: float, tolerance_j: float = DEFAULT_TOLERANCE_J) -> None:
        self.observer = ExchangedEnergyObserver(6, tolerance_j, period_s)
        self._attractor: PoseAttractor | None = None
        self._translation_storage: AttractorStorage | None = None
        self._rotation_storage: AttractorStorage | None = None
        self._rotations: tuple[np.ndarray, np.ndarray] | None = None   # R_d, R of the last tick
        self._rotation_coordinate = np.zeros(3)

    def observe(self, command: ReplicaCommand, attractor: object) -> None:
        """Book one control tick's ``command`` of the task law ``attractor`` (ignored unless a PoseAttractor)."""
        snapshot = command.controller_snapshot
        if not isinstance(attractor, PoseAttractor) or not isinstance(snapshot, PoseAttractorSnapshot):
            return
        if attractor is not self._attractor:   # the first tick, or a rebuilt law: a new run
            self._attractor = attractor
            self._translation_storage = AttractorStorage(attractor.translation.profile)
            self._rotation_storage = AttractorStorage(attractor.rotation.profile)
            self.observer.reset()
            self._rotations, self._rotation_coordinate = None, np.zeros(3)
        desired, measured = command.desired_rotation, command.tcp_rotation
        if self._rotations is not None:
            previous_desired, previous_measured = self._rotations
            step = -pin.log3(measured @ previous_measured.T)
            if not np.array_equal(desired, previous_desired):   # R_d is mostly held: no increment to take
                step += pin.log3(desired @ previous_desired.T)
            self._rotation_coordinate = self._rotation_coordinate + step
        self._rotations = (desired.copy(), measured.copy())
        storage = self._translation_storage(snapshot.translation) + self._rotation_storage(snapshot.rotation.scalar)
        self.observer.observe(command.wrench, np.concatenate((command.tracking_error, self._rotation_coordinate)),
                              storage)


class MasterExchangedEnergy:
    """The master's handle FIC under the exchanged-energy observer (module docstring)."""

    def __init__(self, period_s: float, tolerance_j: float = DEFAULT_TOLERANCE_J) -> None:
        self.observer = ExchangedEnergyObserver(3, tolerance_j, period_s)
        self._attractor: FractalAttractor | None = None
        self._storage: AttractorStorage | None = None
        self._evaluations = 0

    def observe(self, law_evaluations: int, attractor: FractalAttractor) -> None:
        """Book the master's last Eq. 3 evaluation of the handle's ``attractor``, if a new one: ``law_evaluations``
        is the master station's count of them (its ``update`` calls this after each control tick)."""
        if law_evaluations == self._evaluations:
            return   # no new evaluation (no pose yet, or a stale pose commanded zero without one)
        self._evaluations = law_evaluations
        snapshot = attractor.snapshot()
        if attractor is not self._attractor:
            self._attractor, self._storage = attractor, AttractorStorage(attractor.profile)
            self.observer.reset()
        self.observer.observe(snapshot.forces, snapshot.errors, self._storage(snapshot))
