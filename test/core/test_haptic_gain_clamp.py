"""K_H as the master node's parameter pre-set hands it on (master_station.clamped_haptic_gain): the gain MasterLaw
itself takes for the same request (Eq. 3's K_H in [0, 1], a value outside becoming the nearest bound), so the node
logs a clamp exactly when the law would have clamped; NaN and +-Inf pass on unchanged, for MasterLaw to refuse by
name."""
from __future__ import annotations

import math

import pytest

from fic_core.attractor import FractalAttractor
from fic_core.errors import FicInputError
from fic_core.master import MasterLaw
from fic_core.master_station import clamped_haptic_gain
from fic_core.profile import ForceProfile


@pytest.mark.parametrize("requested", [-3.0, -1e-12, 0.0, 0.25, 1.0, 1.0 + 1e-12, 1.5, 10.0])
def test_the_pre_set_clamp_is_the_laws(requested: float) -> None:
    law = MasterLaw(FractalAttractor(ForceProfile(200.0, 0.05, 0.5, 10.0), 3), 0.5)
    clamped = clamped_haptic_gain(requested)
    assert law.set_haptic_gain(requested) == (clamped != requested)
    assert clamped == law.haptic_gain and 0.0 <= clamped <= 1.0


@pytest.mark.parametrize("requested", [math.nan, math.inf, -math.inf])
def test_a_value_that_is_not_finite_passes_on_to_be_refused(requested: float) -> None:
    passed = clamped_haptic_gain(requested)
    assert passed == requested or (math.isnan(passed) and math.isnan(requested))
    law = MasterLaw(FractalAttractor(ForceProfile(200.0, 0.05, 0.5, 10.0), 3), 0.5)
    with pytest.raises(FicInputError, match="haptic_gain"):
        law.set_haptic_gain(passed)
