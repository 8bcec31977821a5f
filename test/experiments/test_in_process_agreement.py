"""The in-process runner against the real graph: one short E1 run (superimposition scene, 200 ms delay both ways)
in lockstep over DDS and the same seconds in one process, and the runner deterministic per seed. The longer
figures (10 s, the speed) come from fic_teleop_experiments.run_in_process.

What can be compared, and how closely (docs/EXPERIMENTS.md, "In-process runner"; measured 2026-12-02 15:18-16:02
against four lockstep runs of this test's launcher command at load averages 4.2, 8.7, 8.7 and 10.0 on 2 cores,
with this test's agreement calls; the test itself then passed at loads 9.4, 6.7 and 11.3):

* Until the operator's first move reaches the replica (sent from about 1.7 s, at the replica from 1.9 s) the
  graph runs are the runner's to within 0.48 mm max and 0.20 mm RMS of |x_d - x_R| in the first three, 0.65 /
  0.27 mm at load 10, 1.64 / 0.71 mm in a fresh-clone suite at load 5-7: the replica's law, the planner, the start and
  the physics agree. A runner that differs there in one term is outside PRE_MOVE_TOLERANCE_M (2.5 mm) or its RMS bound
  (1.2 mm): the linear baseline in place of the FIC 5.3 / 2.6 mm, no joint-damping compensation 3.2 / 2.2 mm, no
  desired-velocity filter 4.9 / 2.2 mm, a fixed point in place of the circle 4.6 / 2.4 mm, K0 doubled 8.2 / 3.9 mm. Not
  seen there: the offset and planner feedforward (nothing to feed forward yet) and a 250 Hz control rate (0.89 / 0.52
  mm).
* After it the graph's own timing decides: the device, master and planner timers may trail the simulation by the peer
  barrier's 11 ms (30 ms when these figures were measured) and the channel nodes by more (held 202 ms at the median,
  up to 353 ms), and the law amplifies a few milliseconds of timing in the x_d' stream (its stamps are the master's
  100 Hz ticks, its content the 250 Hz handle pose before them; the offset-acceleration estimate alternates by about 1
  m/s^2). The runner against itself with the delay 201 instead of 200 ms (RunConfig(delay=0.201, script_delay=0.2)):
  16.7 mm max, 5.0 mm RMS of |e|; against the graph 9.4 / 2.9 mm at load 4, 30.0 / 6.4 mm at load 8.7 and 25.1 / 7.1
  mm at load 10 (27-35 / 6-8 mm in earlier CI runs). Held commands do not matter (7 % of steps on a held torque: 0.12
  mm). So the whole run is held to x_d only, within DESIRED_TOLERANCE_M: 6-39 mm apart measured; 81-104 mm with the
  channel's delay at 1 s, with no x_d' at all, or with a fixed point in place of the circle.
"""
from __future__ import annotations

import numpy as np
import pytest
from conftest import DEFAULT_LOCKSTEP_RUN

pytestmark = pytest.mark.nodes
DURATION_S = float(DEFAULT_LOCKSTEP_RUN[DEFAULT_LOCKSTEP_RUN.index("--duration") + 1])  # 3 s
PRE_MOVE_END_S = 1.9             # [s] the operator's first move reaches the replica (200 ms after it is sent)
PRE_MOVE_TOLERANCE_M = 0.0025    # max | |e|_in-process - |e|_graph | before it (measured 0.48-1.64 mm)
PRE_MOVE_TOLERANCE_RMS_M = 0.0012  # (measured 0.20-0.71 mm)
DESIRED_TOLERANCE_M = 0.060      # max |x_d,in-process - x_d,graph| over the run (measured up to 39 mm)


def test_in_process_run_agrees_with_a_lockstep_graph_run(default_lockstep_run) -> None:
    from fic_teleop_experiments.in_process import RunConfig, agreement, run

    out, process = default_lockstep_run   # the launcher's default graph, DURATION_S lockstep (conftest)
    assert process.returncode == 0, process.stdout + process.stderr
    result = run(RunConfig(duration=DURATION_S))
    again = run(RunConfig(duration=DURATION_S))
    np.testing.assert_array_equal(result.tcp, again.tcp)  # deterministic per seed
    before = agreement(out / "bag", result, end=PRE_MOVE_END_S)
    assert before.samples > 0.8 * (PRE_MOVE_END_S - 0.5) * 100, before
    assert before.error_difference_max <= PRE_MOVE_TOLERANCE_M, before
    assert before.error_difference_rms <= PRE_MOVE_TOLERANCE_RMS_M, before
    whole = agreement(out / "bag", result)
    assert whole.samples > 0.8 * (DURATION_S - 0.5) * 100, whole
    assert whole.desired_difference_max <= DESIRED_TOLERANCE_M, whole
