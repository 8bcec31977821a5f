"""Two ends of the replica's loop-health bounds: a zero tick gap is refused like a zero state age (no tick could
ever be healthy), and the law's share after a resume never passes 1, however late it is asked for."""
from __future__ import annotations

import math

import pytest

from fic_core.errors import FicInputError
from fic_core.loop_health import RESUMING, LoopHealth, LoopHealthBounds


def test_a_zero_tick_gap_is_refused_and_the_least_positive_one_taken() -> None:
    with pytest.raises(FicInputError, match="max_tick_gap"):
        LoopHealthBounds(max_tick_gap=0.0)
    assert LoopHealthBounds(max_tick_gap=math.ulp(0.0)).max_tick_gap > 0.0


@pytest.mark.parametrize("late", [0.1, 0.2, 5.0, 1e6])
def test_the_law_fraction_after_a_resume_is_whole_once_the_ramp_is_over(late: float) -> None:
    bounds = LoopHealthBounds(max_state_age=0.04, max_tick_gap=0.04, resume_ticks=1, resume_ramp=0.1)
    health = LoopHealth(bounds)
    now = 0.002
    health.tick(now, now)
    now += 0.002
    health.tick(now, now - 0.5)          # a state half a second old: the hold
    now += 0.002
    health.tick(now, now)                # one healthy tick resumes
    assert health.state == RESUMING
    assert health.law_fraction(now + late) == 1.0
    assert health.law_fraction(now + 0.05) == pytest.approx(0.5)
