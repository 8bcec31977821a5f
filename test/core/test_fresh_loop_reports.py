"""What a part of the loop reports before anything happened to it: the replica loop's health has seen no tick, no
gap, no hold (every figure 0, HEALTHY, no reason), the master law no saturated device force, the master station no
handle pose; and a via-point list needs at least one point (an empty list is refused in one line, not taken as a
path with nowhere to go)."""
from __future__ import annotations

import pytest
from config_values import config_values

from fic_core.attractor import FractalAttractor
from fic_core.errors import FicInputError
from fic_core.loop_health import HEALTHY, LoopHealth
from fic_core.master import MasterLaw
from fic_core.master_station import MasterParameters, MasterStation
from fic_core.profile import ForceProfile
from fic_core.trajectories import ViaPoints


def test_a_fresh_loop_health_has_seen_nothing() -> None:
    health = LoopHealth()
    assert health.state == HEALTHY and not health.holding and health.reason == ""
    figures = ("state_age", "tick_gap", "command_gap", "state_gap", "max_state_age_seen", "max_tick_gap_seen",
               "max_state_gap_seen", "max_command_gap_seen")
    assert {name: getattr(health, name) for name in figures} == dict.fromkeys(figures, 0.0)
    assert (health.holds, health.held_ticks) == (0, 0)
    # No state of known age and no hold begun: a hold would send nothing (the robot's watchdog holds the arm).
    assert not health.state_fresh
    assert health.hold_command([0.0, -3.0, 0.5, 20.0, 0.6, 2.0, 0.0], [0.1] * 7) is None


def test_a_fresh_master_law_has_saturated_nothing() -> None:
    law = MasterLaw(FractalAttractor(ForceProfile(200.0, 0.05, 0.5, 10.0), 3), 0.5, 20.0)
    assert not law.device_force_saturated and not law.haptic_gain_clamped


def test_a_fresh_master_station_has_no_handle_pose() -> None:
    """Before the device's first pose: no x_M, the identity orientation (a unit quaternion x, y, z, w), the handle at
    rest, nothing received, no feedback, and no teleoperation command to send."""
    station = MasterStation(MasterParameters.from_values(config_values("master.yaml")))
    assert station.handle_position is None and station.network_handle_position is None
    assert station.handle_orientation == (0.0, 0.0, 0.0, 1.0)
    assert station.handle_velocity.tolist() == [0.0, 0.0, 0.0]
    assert station.pose_received is None and station.feedback_received is None and not station.feedback_stale
    assert station.teleoperation_command(0.0) is None


@pytest.mark.parametrize("points", [[], [[]], [[0.1, 0.2]]])
def test_a_via_point_list_without_a_whole_point_is_refused(points) -> None:
    with pytest.raises(FicInputError, match="points must be N x 3"):
        ViaPoints(points)
