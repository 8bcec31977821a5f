"""The shape-sorting operator in the DDS graph (E2): the device node watches the replica's video after the backward
channel, reaches for the first piece, presses it until it feels the contact and lifts it on the bond.

A short lockstep run of ``--scene shape_sorting`` (its default operator): the operator's phases come from the
device node's log, the bond from the robot's ground truth (/sim/object_poses and its bond counter). The full
trials are fic_teleop_experiments.e2.graph (docs/EXPERIMENTS.md "E2")."""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import run_launcher

from sim_bridge.robot.scenes import SHAPE_SORTING_PIECES

pytestmark = pytest.mark.nodes
# The first piece is pressed at about 18 s and lifted at about 19 s of a run (the in-process runner's operator,
# results/e2_operator_fic.json), and the operator sees it rise about a second later.
DURATION_S = 23.0
PHASE = re.compile(r"shape-sorting operator: (\w+):(\w+) at ([\d.]+) s \(([-\d.e+]+)\)")


@pytest.fixture(scope="module")
def sorting_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("shape_sorting") / "run"
    process = run_launcher(out, "--scene", "shape_sorting", "--duration", str(DURATION_S), "--time-mode",
                           "lockstep", "--no-video", "--wall-limit", "500", timeout=700.0)
    assert process.returncode == 0, process.stdout + process.stderr
    return out


def _phases(run: Path) -> list[tuple[str, str, float, float]]:
    log = (run / "logs" / "haptic_device.log").read_text()
    return [(piece, phase, float(start), float(figure)) for piece, phase, start, figure in PHASE.findall(log)]


def test_the_operator_presses_the_first_piece_until_it_feels_it_and_sees_it_bonded(sorting_run: Path) -> None:
    first = SHAPE_SORTING_PIECES[0].shape
    phases = [(phase, start, figure) for piece, phase, start, figure in _phases(sorting_run) if piece == first]
    names = [phase for phase, _, _ in phases]
    assert names[:2] == ["reach", "reach_across"], phases
    felt = [figure for phase, _, figure in phases if phase == "press_felt"]
    assert felt and felt[0] >= 1.0, phases          # the press was felt through the delay (touch_force 1 N)
    assert "carry" in names, phases                  # carry starts only once the piece is seen under the plate


def test_the_piece_rose_on_the_bond_and_the_run_is_safe(sorting_run: Path) -> None:
    from fic_teleop_experiments.shape_sorting import piece_outcomes
    from fic_teleop_tools.verdict.bag_series import read_run

    series = read_run(sorting_run / "bag")
    outcomes = piece_outcomes(series)
    assert outcomes[0].lifted > 0.01, outcomes[0]   # the robot's ground truth: the plate carried the piece up
    assert all(outcome.lifted < 0.005 for outcome in outcomes[1:]), outcomes
    assert int(series.diagnostics["robot_sim"]["bonds_formed"]) >= 1
    metrics = json.loads((sorting_run / "report" / "metrics.json").read_text())
    assert metrics["limit_violations"] == 0
    assert np.isfinite(metrics["peak_interaction_force_n"])
