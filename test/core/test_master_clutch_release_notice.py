"""Releasing the clutch says what the handle does next: engaged again (x_d' continues from where it stood), or,
while the handle is still being homed, that homing goes on (it engages when home, not at the release)."""
from __future__ import annotations

from config_values import config_values

from fic_core.master_station import Engagement, MasterParameters, MasterStation

DEFAULTS = config_values("master.yaml")


def test_a_release_says_engaged_or_homing_goes_on() -> None:
    station = MasterStation(MasterParameters.from_values(DEFAULTS))
    station.add_pose([0.0, 0.0, 0.0], (0, 0, 0, 1), 0.0)
    station.force(0.0)
    assert station.set_clutch(True, "button") == [
        ("info", "clutch held (button): x_d' holds still while the handle moves")]
    assert station.set_clutch(False, "button") == [
        ("info", "clutch released (button): engaged, x_d' continues from where it stood")]
    assert station.engagement == Engagement.ENGAGED

    homing = MasterStation(MasterParameters.from_values({**DEFAULTS, "homing": True}))
    homing.add_pose([0.03, 0.0, 0.0], (0, 0, 0, 1), 0.0)   # 30 mm from the centre: not home
    homing.force(0.0)
    assert homing.engagement == Engagement.HOMING
    homing.set_clutch(True, "button")
    assert homing.set_clutch(False, "button") == [("info", "clutch released (button): homing goes on")]
    assert homing.engagement == Engagement.HOMING
