"""Two of the operator's tools changed while running (master_station's docstring; docs/TOOLS.md, "The operator's
tools"): a fixture switched moves the goal sent to the replica at the replica's own resume speed
(config/replica.yaml's ``resume_speed``, 0.1 m/s: the goal never moves faster than the replica gives a jump
back), and a homing parameter set live is the one the next homing uses."""
from __future__ import annotations

import numpy as np
import pytest
from config_values import config_values
from test_master_station import DEFAULTS, engaged_station, move

from fic_core.master_station import Engagement

RESUME_SPEED = config_values("replica.yaml")["resume_speed"]


def test_a_fixture_switched_on_moves_the_sent_goal_at_the_replicas_resume_speed() -> None:
    assert RESUME_SPEED == 0.1
    station = engaged_station(haptic_gain=0.0)
    handle = np.array([0.01, 0.0, 0.015])   # x_d' = (0.02, 0, 0.03): 30 mm above the plane z = 0
    _, offset, _ = move(station, handle, 0.0)
    station.configure({"guidance_fixture": "plane", "guidance_point": [0.0, 0.0, 0.0],
                       "guidance_direction": [0.0, 0.0, 1.0]})
    sent = [offset] + [move(station, handle, 0.01 * k)[1] for k in range(1, 40)]
    heights = np.array(sent)[:, 2]
    steps = -np.diff(heights)
    # 10 ms network ticks: 1 mm a tick until the 30 mm are given back, then on the plane.
    moving = steps[steps > 1e-12]
    assert moving == pytest.approx(np.full(moving.size, RESUME_SPEED * 0.01), abs=1e-12)
    assert moving.size == pytest.approx(0.03 / (RESUME_SPEED * 0.01), abs=1)
    assert heights[-1] == pytest.approx(0.0, abs=1e-12)


def home(station, position: np.ndarray, now: float, until: float, speeds: list[float]) -> tuple[np.ndarray, float]:
    """A free handle (0.5 kg, 2 N s/m), the station's force held over each 4 ms tick, integrated at 1 ms."""
    velocity = np.zeros(3)
    while station.engagement == Engagement.HOMING and now < until:
        station.add_pose(position, (0, 0, 0, 1), now)
        station.add_twist(velocity, now)
        force, _ = station.force(now)
        for _ in range(4):
            velocity = velocity + 0.001 * (force - 2.0 * velocity) / 0.5
            position = position + 0.001 * velocity
            speeds.append(float(np.linalg.norm(velocity)))
        now += 0.004
    return position, now


def cruise(speed: float) -> float:
    """The homing damper B pulls toward the homing speed against the handle's own 2 N s/m: the handle cruises at
    B / (B + 2) of it (config/master.yaml's B = 10 N s/m: 5/6)."""
    return speed * DEFAULTS["homing_damping"] / (DEFAULTS["homing_damping"] + 2.0)


@pytest.mark.parametrize("speed", [0.02, 0.08])
def test_a_homing_speed_set_live_bounds_the_next_homing(speed: float) -> None:
    station = engaged_station()
    move(station, [0.01, 0.0, 0.0], 0.01)
    station.configure({"homing_speed": speed})
    station.configure({"homing": True})
    assert station.engagement == Engagement.HOMING
    speeds: list[float] = []
    home(station, np.array([0.06, 0.0, 0.0]), 0.02, 10.0, speeds)
    assert station.engagement == Engagement.ENGAGED
    assert max(speeds) == pytest.approx(cruise(speed), rel=1e-3)


def test_a_homing_speed_set_during_a_homing_takes_over_from_the_next_tick() -> None:
    station = engaged_station()
    move(station, [0.01, 0.0, 0.0], 0.01)
    station.configure({"homing": True})
    before: list[float] = []
    position, now = home(station, np.array([0.2, 0.0, 0.0]), 0.02, 1.0, before)
    assert station.engagement == Engagement.HOMING
    assert before[-1] == pytest.approx(cruise(DEFAULTS["homing_speed"]), rel=1e-3)
    station.configure({"homing_speed": 0.01})
    after: list[float] = []
    home(station, position, now, now + 0.5, after)
    assert after[-1] == pytest.approx(cruise(0.01), rel=1e-3)
