"""The exchanged-energy observer at the FIC ports the nodes watch (fic_core.exchanged_energy_ports): the replica's
Cartesian FIC fed from ReplicaLoop's ticks, the master's handle FIC from MasterStation's Eq. 3 evaluations.

Driven from outside round closed loops (the arm's joints, the handle), each port gives back what it took up to the
held-force shortfall, which falls with the period; a loop's rotation coordinate closes; only the FIC is booked
and only ticks that evaluated the law."""
from __future__ import annotations

import math

import numpy as np
import pytest
from config_values import config_values, replica_loop_parameters

from fic_core.exchanged_energy_ports import MasterExchangedEnergy, ReplicaExchangedEnergy
from fic_core.master_station import MasterParameters, MasterStation
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.replica_loop import ReplicaLoop

Q0 = np.array(NOMINAL_CONFIGURATION, dtype=float)
WRIST = np.array([0.0, 0.0, 0.0, 0.15, 0.0, 0.25, 0.35])   # a loop in joints 4, 6, 7: the TCP moves and turns


def arm_loop(controller: str, seconds: float = 2.0) -> tuple[ReplicaLoop, ReplicaExchangedEnergy]:
    """The arm driven round q(t) = Q0 + WRIST sin(2 pi t / seconds) (1 - cos) / 2, one closed loop, the set-point
    held: every control tick of the replica booked by the watch."""
    loop = ReplicaLoop(replica_loop_parameters(controller=controller, answer_every_state=True))
    watch = ReplicaExchangedEnergy(0.001)
    steps = int(round(seconds / 0.001))
    for k in range(steps + 1):
        phase = 2.0 * math.pi * k / steps
        q = Q0 + WRIST * math.sin(phase) * 0.5 * (1.0 - math.cos(phase))
        qd = WRIST * (2.0 * math.pi / seconds) * (math.cos(phase) * 0.5 * (1.0 - math.cos(phase))
                                                  + math.sin(phase) ** 2 * 0.5)
        step = loop.joint_state(k * 0.001, k * 0.001, q, qd)
        if step.command is not None:
            watch.observe(step.command, loop.controller.controller)
    return loop, watch


def test_the_replica_fic_port_round_a_closed_joint_loop() -> None:
    """Once round in 1 s and in 4 s: no violation, the rotation coordinate closes, the storage is back at zero and
    the loop absorbed energy (the convergence phase dissipates); the held force's shortfall is a quarter at a
    quarter of the speed (it is the work of the force's change over a step: proportional to the step)."""
    fast_loop, fast = arm_loop("fic", seconds=1.0)
    _, slow = arm_loop("fic", seconds=4.0)
    assert fast.observer.ticks == fast_loop.controller.ticks == 1001
    for watch in (fast, slow):
        observer = watch.observer
        assert observer.violation_ticks == 0
        assert np.abs(watch._rotation_coordinate).max() < 1e-6
        assert observer.storage_j == pytest.approx(0.0, abs=1e-9)
        assert observer.margin_j > 1.0                  # [J] absorbed round the loop (measured 3.3 J)
    assert 3.0 < fast.observer.shortfall_j / slow.observer.shortfall_j < 5.0   # measured 2 s / 8 s: 13.4 / 3.4 mJ


def test_only_the_fic_is_booked() -> None:
    _, watch = arm_loop("linear", seconds=0.2)
    assert watch.observer.ticks == 0


def test_the_master_fic_port_books_each_evaluation_once() -> None:
    station = MasterStation(MasterParameters.from_values({**config_values("master.yaml"),
                                                          "exchanged_energy_observer": True}))
    watch = station.exchanged                   # the station's own, booked by its control tick
    assert isinstance(watch, MasterExchangedEnergy) and watch.observer.period_s == pytest.approx(0.004)
    station.update(0.0, 0.004)                  # no pose yet: nothing evaluated, nothing booked
    assert watch.observer.ticks == 0
    for k in range(501):                         # the handle round a 3 cm circle in 2 s at 250 Hz
        now = 0.004 * k
        angle = 2.0 * math.pi * now / 2.0
        station.add_pose([0.03 * (1.0 - math.cos(angle)), 0.03 * math.sin(angle), 0.0], (0, 0, 0, 1), now)
        station.add_twist([0.03 * math.pi * math.sin(angle), 0.03 * math.pi * math.cos(angle), 0.0], now)
        station.update(now, 0.004)
        watch.observe(station.law_evaluations, station.law.attractor)   # a second look at the tick books nothing
    assert watch.observer.ticks == 501
    assert watch.observer.violation_ticks == 0
    station.update(2.0 + 1.0, 0.004)             # the pose is stale: zero commanded, the law not evaluated
    assert watch.observer.ticks == 501
    assert set(watch.observer.diagnostics()) >= {"shortfall_j", "damping_needed", "min_margin_j", "violation_ticks"}
