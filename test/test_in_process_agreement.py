"""The in-process runner against the real graph: one short E1 run (superimposition scene, 200 ms delay both ways)
in lockstep over DDS and the same seconds in one process must give the same tracking-error trace within
TOLERANCE_M, and the runner must be deterministic per seed. The longer figures (10 s, the speed) come from
scripts/in_process.py."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from conftest import REPO, isolated_env, reserved_domain

pytestmark = pytest.mark.nodes
DURATION_S = 3.0
#: Largest difference of |x_d - x_R| between the two runs over [0.5 s, end] [m] (docs/EXPERIMENTS.md, "In-process
#: runner"): the graph delivers each message a step or two later than the runner, and on a loaded machine a
#: lockstep wait that times out steps the robot on a held command (271 of 4055 steps in the run that set these).
TOLERANCE_M = 0.025
TOLERANCE_RMS_M = 0.006


# Known defect, kept visible: on main at 764430f, on a quiet machine, the traces differed by 35.3 mm max and 7.9 mm
# RMS (graph 11.3 mm RMS, runner 8.3 mm). With the input authority in the runner too (2026-12-02 13:10, load
# average 8): 27.3 mm max, 5.97 mm RMS (graph 9.8 mm RMS, runner 8.3 mm). The authority does not explain the gap
# (E1's x_d' stays far inside its bounds); the cause is not known yet.
@pytest.mark.xfail(reason="runner and lockstep graph differ by up to 27-35 mm since the passive attractor "
                          "landed; cause not yet found", strict=False)
def test_in_process_run_agrees_with_a_lockstep_graph_run(tmp_path) -> None:
    from sim_bridge.experiments.in_process import RunConfig, agreement, run

    out = tmp_path / "run"
    with reserved_domain() as domain:
        env = isolated_env(tmp_path / "ros_log", domain)
        process = subprocess.run([sys.executable, str(REPO / "scripts" / "teleop_launcher.py"), "--out", str(out),
                                  "--duration", str(DURATION_S), "--time-mode", "lockstep", "--no-video",
                                  "--no-report", "--wall-limit", "400"], env=env, capture_output=True, text=True,
                                 timeout=600)
    assert process.returncode == 0, process.stdout + process.stderr
    result = run(RunConfig(duration=DURATION_S))
    again = run(RunConfig(duration=DURATION_S))
    np.testing.assert_array_equal(result.tcp, again.tcp)  # deterministic per seed
    figures = agreement(out / "bag", result)
    assert figures.samples > 0.8 * (DURATION_S - 0.5) * 100, figures
    assert figures.error_difference_max <= TOLERANCE_M, figures
    assert figures.error_difference_rms <= TOLERANCE_RMS_M, figures
