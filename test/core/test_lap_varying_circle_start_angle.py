"""LapVaryingCircle.randomised's start angle by default: drawn uniformly from the whole turn [0, 2 pi) (its
docstring: uniformly in one of ``phase_ranges``, by default the one full turn), so over a few dozen seeds every
eighth of the circle is a start."""
from __future__ import annotations

import math

import numpy as np

from fic_core.trajectories import LapVaryingCircle


def test_the_default_start_angle_is_anywhere_on_the_whole_turn() -> None:
    phases = [LapVaryingCircle.randomised([0.4, 0.0, 0.4], np.random.default_rng(seed), 5.0).phase
              for seed in range(64)]
    assert all(0.0 <= phase < 2.0 * math.pi for phase in phases)
    assert {int(phase // (math.pi / 4.0)) for phase in phases} == set(range(8))
