"""The closed-loop operator in the in-process E1 run (fic_teleop_experiments.in_process, operator="closed_loop").

At 1 s one-way delay the operator times its avoid move from the delayed video and the replica passes the fixed
obstacle on the second lap without touching it, where the E1 script timed for 0.2 s touches it on that lap (its
moves reach the replica 0.8 s late). The first lap is not judged: the robot starts its circle at 1.8 s and at 1 s
delay the operator first sees it move at 2.8 s, after its move had to start. Measured (seed 1, 10.8 s, contact
seconds on laps 1 and 2, ``contact_per_lap``): closed loop 1.76 and 0.00, script timed for 0.2 s 0.69
and 0.45, script timed for 1 s 0.00 and 0.00.
"""
from __future__ import annotations

import numpy as np
import pytest

from fic_teleop_experiments.in_process import RunConfig, run

#: E1's lap: the planner's circle and the operator's script repeat every 5 s; the laps of the contact count are
#: centred on the planner's passings of the fixed obstacle (3.25 s + 5 k).
LAP_S, FIRST_LAP_START_S = 5.0, 0.75
SECOND_LAP = (5.75, 10.75)  # [s] the second lap, around the fixed obstacle's passing (x_d there at 8.25 s)
DURATION = 10.8


def contact_per_lap(time: np.ndarray, contact: np.ndarray) -> list[float]:
    """Seconds of fixed-obstacle contact in each whole lap of the run."""
    step = float(np.median(np.diff(time)))
    laps = int((time[-1] - FIRST_LAP_START_S) // LAP_S)
    return [round(float(np.sum(contact[(time >= FIRST_LAP_START_S + k * LAP_S)
                                       & (time < FIRST_LAP_START_S + (k + 1) * LAP_S)]) * step), 4)
            for k in range(laps)]


@pytest.mark.xfail(strict=True, reason=(
    "open since the low-rate command path (fic_core/link_hold.py): the same commands move the arm 6.6-8.9 mm "
    "differently in the first lap's moves (5-7 s), the operator starts its second avoid 0.9 s later (7.42 s, was "
    "6.53 s) and the arm touches the obstacle for 0.8 s on lap 2 (was 0.0; the 0.2 s script 0.39 s); every seed "
    "alike (docs/RESULTS.md, \"Evidence and claims\")"))
def test_at_one_second_delay_the_closed_loop_operator_clears_the_obstacle_where_the_short_delay_script_does_not():
    closed = run(RunConfig(delay=1.0, duration=DURATION, operator="closed_loop", seed=1))
    assert [name for name, _, passing in closed.operator_moves if SECOND_LAP[0] < passing < SECOND_LAP[1]] \
        == ["avoid"]
    assert contact_per_lap(closed.time, closed.obstacle_contact)[1] == 0.0
    late = run(RunConfig(delay=1.0, duration=DURATION, operator="scripted", script_delay=0.2, seed=1))
    assert contact_per_lap(late.time, late.obstacle_contact)[1] > 0.1


def test_a_closed_loop_run_is_the_same_for_a_seed_and_not_for_another():
    options = dict(delay=0.5, duration=4.0, operator="closed_loop", jitter=0.005, operator_timing_jitter=0.1,
                   hand_impedance_jitter=0.2)
    first, again, other = (run(RunConfig(seed=seed, **options)) for seed in (3, 3, 4))
    assert first.operator_moves == again.operator_moves and first.operator_moves
    np.testing.assert_array_equal(first.master, again.master)
    np.testing.assert_array_equal(first.tcp, again.tcp)
    assert not np.array_equal(first.master, other.master)
