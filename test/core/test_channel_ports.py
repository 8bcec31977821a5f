"""The channel's two ports as the master and the replica station hold them (fic_core.channel_ports): each port's
power booked from what that side can measure, the per-direction generated energy and its windowed rate, TDPA acting
through the master station's control tick, and the two halves across a delay summing to what one process sums."""
from __future__ import annotations

from collections import deque

import numpy as np
import pytest
from config_values import config_values

from fic_core.channel_ports import ChannelPorts, MasterChannelPort, ReplicaChannelPort
from fic_core.errors import FicInputError
from fic_core.master_station import MasterParameters, MasterStation
from fic_core.windowed_rate import WindowedRate

DEFAULTS = config_values("master.yaml")   # offset mode, s_M = 1, feedback_timeout 0.5 s
PARAMETERS = MasterParameters.from_values(DEFAULTS)
DT = 0.004                                # the master's 250 Hz


def station_moving(velocity: list[float], port: MasterChannelPort | None = None) -> MasterStation:
    station = MasterStation(PARAMETERS, channel_port=port)
    station.add_pose([0.0, 0.0, 0.0], (0, 0, 0, 1), 0.0)
    station.add_twist(velocity, 0.0)
    return station


def test_the_rate_is_the_totals_change_over_the_window() -> None:
    rate = WindowedRate(1.0)
    assert rate.rate == 0.0
    for k in range(301):                   # a total growing 2 per second for 3 s, sampled at 100 Hz
        rate.add(0.01 * k, 2.0 * 0.01 * k)
    assert rate.rate == pytest.approx(2.0)
    for k in range(301, 501):              # then flat for 2 s: the window forgets the growth
        rate.add(0.01 * k, 6.0)
    assert rate.rate == pytest.approx(0.0)
    with pytest.raises(FicInputError):
        WindowedRate(0.0)


def test_the_master_port_books_minus_f_dot_the_offsets_rate() -> None:
    port = MasterChannelPort(False, 125.0)
    station = station_moving([0.1, 0.0, 0.0], port)   # offset mode, s_M = 1: x_d' moves at the handle's 0.1 m/s
    port.receive_feedback([-2.0, 0.0, 0.0], 0.0)    # F_R against the motion: energy goes into the channel
    for k in range(10):
        station.update(k * DT, DT)
    assert port.observer.input_energy == pytest.approx(10 * 2.0 * 0.1 * DT)
    assert port.observer.output_energy == 0.0
    port.receive_feedback([2.0, 0.0, 0.0], 10 * DT)  # F_R along the motion: the channel gives energy out
    station.update(10 * DT, DT)
    assert port.observer.output_energy == pytest.approx(2.0 * 0.1 * DT)
    assert port.generated_energy == pytest.approx(2.0 * 0.1 * DT)   # the replica has sent no E_in yet
    port.receive_energy(1.0)
    assert port.generated_energy == pytest.approx(2.0 * 0.1 * DT - 1.0)
    stale = 10 * DT + DEFAULTS["feedback_timeout"] + 0.1              # a stale F_R is booked as rendered: zero
    station.update(stale, DT)
    assert port.observer.output_energy == pytest.approx(2.0 * 0.1 * DT)
    assert port.diagnostics()["passivity_control"] == 0.0
    station.set_clutch(True, "test")                  # x_d' holds still: no rate, nothing booked
    port.receive_feedback([2.0, 0.0, 0.0], stale)
    station.update(stale + DT, DT)
    assert port.observer.output_energy == pytest.approx(2.0 * 0.1 * DT)
    assert port.tick(stale + DT, DT, np.array([0.1, 0.0, 0.0]), DEFAULTS["feedback_timeout"]) is None   # no TDPA


def test_tdpa_at_the_master_damps_what_the_station_renders() -> None:
    port = MasterChannelPort(True, 1e6)
    station = station_moving([0.1, 0.0, 0.0], port)
    station.add_feedback([2.0, 0.0, 0.0], 0.0)       # would give out 0.2 W that nobody put in
    station.update(0.0, DT)
    force, _ = station.feedback_force(0.0)
    assert force[0] == pytest.approx(0.0, abs=1e-12)   # F - alpha v lets out nothing: W stays at zero
    assert port.controller.damping == pytest.approx(2.0 / 0.1)
    assert port.observer.energy == pytest.approx(0.0, abs=1e-12)
    assert port.observer.negative_ticks == 0
    station.add_feedback([-2.0, 0.0, 0.0], DT)        # energy going in is never damped
    station.update(DT, DT)
    np.testing.assert_allclose(station.feedback_force(DT)[0], [-2.0, 0.0, 0.0])


def test_the_replica_port_books_f_dot_the_delivered_offsets_rate() -> None:
    port = ReplicaChannelPort(False)
    assert port.sent([1.0, 0.0, 0.0]) == 0.0
    np.testing.assert_allclose(port.delivery([0.0, 0.0, 0.0], 0.0), [0.0, 0.0, 0.0])
    np.testing.assert_allclose(port.delivery([0.01, 0.0, 0.0], 0.004), [0.01, 0.0, 0.0])
    assert port.observer.input_energy == pytest.approx(1.0 * 0.01)    # F_R . dx: into the channel
    port.sent([-1.0, 0.0, 0.0])
    port.delivery([0.02, 0.0, 0.0], 0.008)
    assert port.observer.output_energy == pytest.approx(0.01)
    assert port.generated_energy == pytest.approx(0.01)
    assert port.diagnostics()["offset_drift_m"] == 0.0


def test_two_halves_across_a_delay_sum_as_one_process() -> None:
    """A handle moving sinusoidally, F_R a spring on the delayed offset: each half only knows the other's E_in one
    delay late, yet E_out,M + E_out,R - E_in,M - E_in,R is ChannelPorts' balance, and the per-direction figures are
    -W of each side."""
    ports = ChannelPorts(False, 125.0)
    station = MasterStation(PARAMETERS, channel_port=ports.master)
    lag = 50                                           # 0.2 s at DT
    forward: deque = deque([None] * lag)
    backward: deque = deque([None] * lag)
    for k in range(2000):
        now = k * DT
        position = 0.05 * np.array([np.sin(2.0 * now), 0.0, 0.0])
        station.add_pose(position, (0, 0, 0, 1), now)
        station.add_twist(0.1 * np.array([np.cos(2.0 * now), 0.0, 0.0]), now)
        station.update(now, DT)
        forward.append((position.copy(), ports.master.input_energy))
        delivered = forward.popleft()
        if delivered is not None:
            ports.replica.receive_energy(delivered[1])
            offset = ports.replica.delivery(delivered[0], now)
            backward.append((-200.0 * offset, ports.replica.sent(-200.0 * offset)))
        else:
            backward.append(None)
        returned = backward.popleft()
        if returned is not None:
            station.add_feedback(returned[0], now, replica_input_energy=returned[1])
    master, replica = ports.master.observer, ports.replica.observer
    assert master.ticks == 2000 and replica.ticks == 2000 - lag - 1   # the first delivery has no rate yet
    lagged = ports.master.generated_energy + ports.replica.generated_energy
    balance = ports.generated_energy
    assert abs(balance) > 1e-3                         # the delay does move energy around here
    # The halves' sum differs from the balance by exactly what is in flight (E_in not yet received).
    in_flight = (master.input_energy - replica.received_input_energy) + \
        (replica.input_energy - master.received_input_energy)
    assert lagged == pytest.approx(balance + in_flight)
