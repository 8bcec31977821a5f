"""The handle's velocity differenced from its poses (fic_core.master_station.MasterStation.add_pose, no twist from
the device) over at least MIN_VELOCITY_INTERVAL_S: two poses closer than that, a driver's duplicate or a subnormal
interval, leave the velocity as it was instead of a huge or infinite one (the newer position is differenced next,
from the last difference's time), and a clock that steps back starts the differences again."""
from __future__ import annotations

import numpy as np
from config_values import config_values

from fic_core.master_station import MIN_VELOCITY_INTERVAL_S, MasterParameters, MasterStation


def _station() -> MasterStation:
    return MasterStation(MasterParameters.from_values(config_values("master.yaml")))


def _moving(start: float) -> MasterStation:
    """A station whose handle moved 1 mm along x in one device period (4 ms) from ``start``: 0.25 m/s."""
    station = _station()
    station.add_pose([0.0, 0.0, 0.0], (0, 0, 0, 1), start)
    station.add_pose([0.001, 0.0, 0.0], (0, 0, 0, 1), start + 0.004)
    return station


def test_poses_a_period_apart_give_their_difference() -> None:
    np.testing.assert_allclose(_moving(1.0).handle_velocity, (0.25, 0.0, 0.0))


def test_poses_too_close_keep_the_velocity_and_the_next_differences_from_the_last_used() -> None:
    station = _moving(1.0)
    for interval in (5e-324, 1e-9, 0.5 * MIN_VELOCITY_INTERVAL_S):   # a subnormal interval made an infinite one
        station.add_pose([0.002, 0.0, 0.0], (0, 0, 0, 1), 1.004 + interval)
        assert np.all(np.isfinite(station.handle_velocity))
        np.testing.assert_allclose(station.handle_velocity, (0.25, 0.0, 0.0))
    # From the newest position, at the time of the last difference (as a burst of poses received at once).
    station.add_pose([0.003, 0.0, 0.0], (0, 0, 0, 1), 1.008)
    np.testing.assert_allclose(station.handle_velocity, (0.25, 0.0, 0.0))


def test_a_clock_that_steps_back_starts_the_differences_again() -> None:
    station = _moving(10.0)
    station.add_pose([0.5, 0.0, 0.0], (0, 0, 0, 1), 2.0)   # back 8 s: no velocity from across the step
    np.testing.assert_allclose(station.handle_velocity, (0.25, 0.0, 0.0))
    station.add_pose([0.501, 0.0, 0.0], (0, 0, 0, 1), 2.004)
    np.testing.assert_allclose(station.handle_velocity, (0.25, 0.0, 0.0))
