"""The planner station outside ROS (fic_core.planner_station): x_d'' from config/planner.yaml's trajectory on the
station's clock, the run-time changes all or none, the start pose."""
from __future__ import annotations

import numpy as np
import pytest
from config_values import config_values

from fic_core.errors import FicInputError
from fic_core.planner_station import PlannerParameters, PlannerStation, make_source


def values(**changes) -> PlannerParameters:
    """config/planner.yaml's values, changed, as the station takes them."""
    return PlannerParameters.from_values({**config_values("planner.yaml"), "start_position": [], **changes})


def test_the_station_starts_on_the_trajectory_and_follows_its_clock() -> None:
    station = PlannerStation(values(start_time=1.0), 0.0)
    circle = make_source(values())
    first = station.update(0.0)
    np.testing.assert_allclose(first.position, circle.point(0.0))
    np.testing.assert_allclose(first.orientation, [1.0, 0.0, 0.0, 0.0])
    for k in range(1, 101):   # before start_time the trajectory's clock stands at 0: x_d'' stays
        point = station.update(0.01 * k)
    np.testing.assert_allclose(point.position, circle.point(0.0), atol=1e-12)
    for k in range(101, 300):
        point = station.update(0.01 * k)
    assert np.linalg.norm(point.position - circle.point(0.0)) > 0.05   # moving round the circle
    assert np.linalg.norm(point.acceleration) > 0.0 and station.published == 300


def test_a_negative_start_time_starts_the_clock_start_delay_after_the_station() -> None:
    station = PlannerStation(values(start_time=-1.0, start_delay=2.0), 5.0)
    assert station.schedule.origin == 7.0


def test_changes_are_checked_before_any_is_applied() -> None:
    station = PlannerStation(values(), 0.0)
    with pytest.raises(FicInputError, match="fixed at start"):
        station.configure({"publish_rate": 50.0}, 1.0)
    with pytest.raises(FicInputError):
        station.configure({"trajectory": "spiral", "natural_frequency": 4.0}, 1.0)
    with pytest.raises(FicInputError, match="natural_frequency must be in"):
        station.configure({"trajectory": "fixed", "natural_frequency": -1.0}, 1.0)
    assert station.planner.natural_frequency == 8.0 and station.parameters.trajectory == "circle"
    notices = station.configure({"trajectory": "fixed", "natural_frequency": 4.0, "use_sim_time": True}, 1.0)
    assert len(notices) == 2 and station.planner.natural_frequency == 4.0
    assert station.schedule.origin == 1.0 and station.diagnostic_values()["trajectory"] == "fixed"
    assert station.parameters.trajectory == "fixed" and station.parameters.natural_frequency == 4.0


def test_a_name_no_row_has_is_refused_where_the_parameters_are_built() -> None:
    with pytest.raises(FicInputError, match="^unknown planner parameter 'natural_frequncy'; did you mean "
                                            "'natural_frequency'"):
        values(natural_frequncy=4.0)


def test_the_station_integrates_one_publish_period_a_tick() -> None:
    """The schedule's nominal step is the period of config/planner.yaml's publish_rate, 1 / rate."""
    station = PlannerStation(values(publish_rate=250.0), 0.0)
    assert station.schedule.nominal_period == pytest.approx(1.0 / 250.0)
