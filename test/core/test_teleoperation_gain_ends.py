"""The teleoperation integrator's gains at the ends of their ranges (teleoperation.py: s_M > 0, k_v >= 0, the
dead-band >= 0), given at construction or set live (the master's parameter dispatch): the smallest ones in range
are taken, a zero scale or a negative gain or dead-band refused by name, and a refusal leaves the gain as it was."""
from __future__ import annotations

import pytest

from fic_core.errors import FicInputError
from fic_core.teleoperation import TeleoperationCommandIntegrator

IN_RANGE = {"workspace_scale": 0.01, "velocity_gain": 0.0, "velocity_deadband": 0.0}
ALSO_IN_RANGE = {"workspace_scale": 0.5, "velocity_gain": 0.5, "velocity_deadband": 0.5}
PAST = {"workspace_scale": 0.0, "velocity_gain": -1e-9, "velocity_deadband": -1e-9}


@pytest.mark.parametrize("name", list(IN_RANGE))
def test_each_gain_takes_its_range_end_and_refuses_the_value_past_it(name: str) -> None:
    for value in (IN_RANGE[name], ALSO_IN_RANGE[name]):
        assert getattr(TeleoperationCommandIntegrator(**{name: value}), name) == value
        integrator = TeleoperationCommandIntegrator()
        setattr(integrator, name, value)
        assert getattr(integrator, name) == value
    with pytest.raises(FicInputError, match=name):
        TeleoperationCommandIntegrator(**{name: PAST[name]})
    integrator = TeleoperationCommandIntegrator(**{name: ALSO_IN_RANGE[name]})
    with pytest.raises(FicInputError, match=name):
        setattr(integrator, name, PAST[name])
    assert getattr(integrator, name) == ALSO_IN_RANGE[name]
