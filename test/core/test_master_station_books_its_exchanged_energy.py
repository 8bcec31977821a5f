"""The master station's control tick books the handle FIC's port itself (fic_core.master_station, "update": the
channel's master port, Eq. 3, the handle FIC's exchanged energy): with exchanged_energy_observer on, each update
that evaluated Eq. 3 is one observer tick, with no other call; with it off, there is no observer."""
from __future__ import annotations

import math

from config_values import config_values

from fic_core.master_station import MasterParameters, MasterStation

PERIOD = 0.004


def station(observer: bool) -> MasterStation:
    return MasterStation(MasterParameters.from_values({**config_values("master.yaml"),
                                                       "exchanged_energy_observer": observer}))


def test_each_evaluating_update_is_one_observer_tick() -> None:
    master = station(True)
    for k in range(50):
        now = PERIOD * k
        angle = math.pi * now
        master.add_pose([0.02 * math.sin(angle), 0.01 * (1.0 - math.cos(angle)), 0.0], (0, 0, 0, 1), now)
        master.update(now, PERIOD)
        assert master.exchanged.observer.ticks == master.law_evaluations == k + 1
    assert station(False).exchanged is None
