"""PassivityObserver: port work, storage and margin per axis; violations counted; the attractor reads clean."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.attractor import FractalAttractor
from fic_core.errors import FicInputError
from fic_core.passivity_observer import PassivityObserver
from fic_core.pose_attractor import PoseAttractor
from fic_core.profile import ForceProfile


def test_a_spring_that_gives_out_energy_is_flagged() -> None:
    """A 'spring' whose storage grows more than the work put in: the margin goes negative and ticks are counted."""
    observer = PassivityObserver(1)
    observer.observe([0.0], [0.0], [0.0])
    observer.observe([0.01], [1.0], [0.005])  # work 0.01, storage +0.005: margin +0.005
    assert observer.margin[0] == pytest.approx(0.005) and observer.violation_ticks == 0
    observer.observe([0.02], [1.0], [0.03])  # work 0.02, storage +0.03: margin -0.01
    assert observer.margin[0] == pytest.approx(-0.01)
    assert observer.violation_ticks == 1 and observer.min_margin == pytest.approx(-0.01)
    assert observer.port_work[0] == pytest.approx(0.02) and observer.storage[0] == 0.03


def test_the_attractor_under_the_issue_cycle_reads_no_violation_and_a_growing_margin() -> None:
    attractor = FractalAttractor(ForceProfile(200.0, 0.05, 0.5, 15.0), 1, 0.005)
    observer = PassivityObserver(1)
    knots = [0.0, 0.04] + [0.028, 0.04] * 5 + [0.0]
    margins = []
    for first, last in zip(knots[:-1], knots[1:]):
        for error in np.linspace(first, last, 200)[1:]:
            attractor.force([error], [np.sign(last - first) * 0.1])
            observer.observe_snapshot(attractor.snapshot())
            margins.append(observer.margin[0])
    assert observer.violation_ticks == 0 and observer.min_margin >= -1e-12
    assert np.all(np.diff(margins) >= -1e-12)  # the FIC's margin only grows: each tick adds its dissipation


def test_pose_snapshot_has_six_ports_and_a_restart_keeps_the_run_figures() -> None:
    pose = PoseAttractor(ForceProfile(200.0, 0.05, 0.5, 10.0), ForceProfile(20.0, 0.5, 0.5, 5.0))
    observer = PassivityObserver(6)
    pose.wrench([0.01, 0, 0], [0, 0, 0.1], np.zeros(6))
    observer.observe_snapshot(pose.snapshot())
    pose.wrench([0.02, 0, 0], [0, 0, 0.2], np.zeros(6))
    observer.observe_snapshot(pose.snapshot())
    # Slot rx books the rotation angle's port (fic_core/rotational_attractor.py); ry and rz stay empty.
    assert observer.port_work.shape == (6,) and observer.port_work[0] > 0 and observer.port_work[3] > 0
    assert observer.port_work[4] == observer.port_work[5] == 0.0
    observer.observe([0.0] * 6, [0.0] * 6, [1.0] * 6)  # storage jumps with no work: a violation
    assert observer.violation_ticks == 1
    observer.restart_port()
    observer.observe([0.0] * 6, [0.0] * 6, [5.0] * 6)  # a new storage baseline, not a violation
    assert observer.violation_ticks == 1 and np.all(observer.port_work == 0) and np.all(observer.margin == 0)
    with pytest.raises(FicInputError):
        observer.observe([0.0], [0.0], [0.0])
    with pytest.raises(FicInputError):
        PassivityObserver(0)
