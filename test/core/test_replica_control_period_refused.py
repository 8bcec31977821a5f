"""A replica control period of zero or less is refused in one line naming it, before anything else is compared
with it (an optimisation built for another period has its own line)."""
from __future__ import annotations

import pytest
from test_replica_handover import paper_fic

from fic_core.errors import FicInputError
from fic_core.limits import PandaLimits
from fic_core.postural_optimisation import PosturalOptimisation
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel


@pytest.mark.parametrize("period", [0.0, -0.0, -0.001])
def test_a_control_period_of_zero_or_less_is_refused_naming_it(robot: RobotModel, limits: PandaLimits,
                                                               period: float) -> None:
    with pytest.raises(FicInputError, match=r"^control_period must be > 0"):
        ReplicaController(robot, paper_fic(), control_period=period)
    with pytest.raises(FicInputError, match=r"^control_period must be > 0"):
        ReplicaController(robot, paper_fic(), control_period=period,
                          optimisation=PosturalOptimisation(limits, 0.001))
