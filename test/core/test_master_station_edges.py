"""Two edges of the master station (fic_core.master_station): the handle pose is carried forward by its velocity
up to an age of handle_extrapolation inclusive ("at most", docs/CONTROL_LAWS.md "The handle at the network
tick"), and no further; the zero force the station shows while there is no guidance fixture (and renders as F_R
while the clutch is held) is read only, so a reader writing into it can change no station's later forces."""
from __future__ import annotations

import numpy as np
import pytest
from config_values import config_values

from fic_core.master_station import MasterParameters, MasterStation

DEFAULTS = config_values("master.yaml")
EXTRAPOLATION = 2.0 ** -6   # [s], a binary fraction: an age of exactly this is exact


def master(**changes) -> MasterStation:
    return MasterStation(MasterParameters.from_values({**DEFAULTS, **changes}))


def test_the_handle_is_carried_forward_up_to_exactly_handle_extrapolation() -> None:
    station = master(handle_extrapolation=EXTRAPOLATION)
    station.add_pose([0.25, 0.0, -0.125], (0, 0, 0, 1), 1.0)
    station.add_twist([0.5, -0.25, 0.0], 1.0)
    at_the_bound = 1.0 + EXTRAPOLATION
    assert at_the_bound - 1.0 == EXTRAPOLATION
    np.testing.assert_array_equal(station.handle_at(at_the_bound),
                                  [0.25 + 0.5 * EXTRAPOLATION, -0.25 * EXTRAPOLATION, -0.125])
    np.testing.assert_array_equal(station.handle_at(float(np.nextafter(at_the_bound, 2.0))), [0.25, 0.0, -0.125])
    np.testing.assert_array_equal(station.handle_at(0.5 * EXTRAPOLATION + 1.0),
                                  [0.25 + 0.25 * EXTRAPOLATION, -0.125 * EXTRAPOLATION, -0.125])


def test_the_stations_zero_force_is_read_only() -> None:
    station = master()
    shown = station.guidance_force
    np.testing.assert_array_equal(shown, np.zeros(3))
    with pytest.raises(ValueError):
        shown[0] = 5.0
    # Whatever a reader tried, a station's guidance force and its clutched F_R are still zero.
    clutched = master(clutch=True)
    np.testing.assert_array_equal(clutched.guidance_force, np.zeros(3))
    free = master(clutch=True, haptic_gain=0.0)
    for station in (clutched, free):
        station.add_pose([0.01, 0.0, 0.0], (0, 0, 0, 1), 1.0)
        station.add_feedback([3.0, 0.0, 0.0], 1.0)
    np.testing.assert_array_equal(clutched.force(1.0)[0], free.force(1.0)[0])   # F_R unfelt with the clutch held
