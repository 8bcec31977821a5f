"""The delay/dropout channel's logic (sim_bridge/channel/channel.py), on a simulated clock: no ROS, no wall time."""
from __future__ import annotations

import math

import numpy as np
import pytest
from config_values import config_values
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.errors import FicInputError
from sim_bridge.channel.channel import Channel, ChannelConfig
from sim_bridge.channel.channel_parameters import ChannelParameters, channel_config

TICK = 0.001   # the node's delivery timer period


def run(channel: Channel, send_times, end: float, tick: float = TICK):
    """Push message i (payload i, stamp = send time) at send_times[i]; poll every tick; return deliveries with
    their release time."""
    send_times = list(send_times)
    released = []
    next_send = 0
    steps = int(math.ceil(end / tick))
    for step in range(steps + 1):
        now = step * tick
        while next_send < len(send_times) and send_times[next_send] <= now + 1e-12:
            channel.push(next_send, send_times[next_send], send_times[next_send])
            next_send += 1
        for delivery in channel.pop_due(now):
            released.append((now, delivery))
    return released


def test_fixed_delay_is_exact_on_the_poll_grid():
    channel = Channel(ChannelConfig(delay=0.2))
    sends = np.arange(0.0, 1.0, 0.004)
    released = run(channel, sends, 1.5)
    assert len(released) == len(sends)
    for now, delivery in released:
        assert delivery.held == pytest.approx(0.2, abs=TICK + 1e-9)    # one poll period late at most
        assert now - delivery.stamp == pytest.approx(0.2, abs=TICK + 1e-9)
        assert now >= delivery.stamp + 0.2 - 1e-9        # never early
    stats = channel.statistics()
    assert stats.held_p50 == pytest.approx(0.2, abs=TICK + 1e-9)
    assert stats.delivered == len(sends) and stats.dropped_total == 0 and stats.queue_size == 0


def test_nothing_is_released_before_its_due_time():
    channel = Channel(ChannelConfig(delay=0.05))
    channel.push(b"x", 0.0, 0.0)
    assert channel.pop_due(0.0499) == []
    assert channel.next_due_time() == pytest.approx(0.05)
    assert [d.payload for d in channel.pop_due(0.05)] == [b"x"]


@pytest.mark.parametrize("distribution", ["uniform", "normal"])
def test_jitter_stays_within_its_bounds_and_keeps_fifo(distribution):
    channel = Channel(ChannelConfig(delay=0.1, jitter=0.03, jitter_distribution=distribution, seed=3))
    sends = np.arange(0.0, 2.0, 0.002)     # 500 msg/s: consecutive hold times overlap, reordering would show
    released = run(channel, sends, 2.5)
    payloads = [d.payload for _, d in released]
    assert payloads == sorted(payloads) == list(range(len(sends)))
    held = np.array([d.held for _, d in released])
    assert held.min() >= 0.07 - 1e-9 and held.max() <= 0.13 + TICK + 1e-9
    assert held.std() > 0.005                           # the jitter is really there


def test_jitter_reorders_only_when_allowed():
    channel = Channel(ChannelConfig(delay=0.1, jitter=0.03, allow_reorder=True, seed=3))
    released = run(channel, np.arange(0.0, 1.0, 0.002), 1.5)
    payloads = [d.payload for _, d in released]
    assert sorted(payloads) == list(range(500)) and payloads != sorted(payloads)


def test_jitter_never_makes_a_negative_hold():
    channel = Channel(ChannelConfig(delay=0.001, jitter=0.01, seed=1))
    released = run(channel, np.arange(0.0, 0.5, 0.002), 1.0)
    assert all(d.held >= 0.0 for _, d in released)


@pytest.mark.parametrize("probability", [0.1, 0.5])
def test_drop_rate_matches_the_probability(probability):
    n = 20_000
    channel = Channel(ChannelConfig(drop_probability=probability, seed=11))
    for i in range(n):
        channel.push(i, None, i * 1e-3)
    delivered = len(channel.pop_due(n * 1e-3))
    dropped = channel.statistics().dropped["random"]
    assert delivered + dropped == n
    # Binomial: 5 standard deviations either side (a false failure about once in 2 million runs).
    sigma = math.sqrt(n * probability * (1.0 - probability))
    assert abs(dropped - n * probability) < 5.0 * sigma


def test_blackout_window_delivers_nothing_inside_and_resumes_after():
    channel = Channel(ChannelConfig(delay=0.05, blackout_windows=((1.0, 2.0),)))
    released = run(channel, np.arange(0.0, 3.0, 0.004), 3.5)
    release_times = np.array([now for now, _ in released])
    assert not np.any((release_times >= 1.0) & (release_times < 2.0))
    assert np.any(release_times >= 2.0) and np.any(release_times < 1.0)
    stats = channel.statistics()
    # Lost: sent inside the window (250), plus sent in the 50 ms before it (would arrive inside: 12-13).
    assert 255 <= stats.dropped["blackout"] <= 265
    assert stats.delivered + stats.dropped_total == len(release_times) + stats.dropped_total == 750


def test_lost_from_delivers_nothing_afterwards():
    channel = Channel(ChannelConfig(delay=0.2, lost_from=1.0))
    released = run(channel, np.arange(0.0, 3.0, 0.004), 3.5)
    assert max(now for now, _ in released) < 1.0
    assert channel.statistics().dropped["lost"] == 750 - len(released)


def test_rate_cap_delivers_at_most_n_per_second_keeping_the_newest():
    channel = Channel(ChannelConfig(delay=0.0, rate_cap_hz=10.0))
    sends = np.arange(0.0, 5.0, 0.001)                 # 1 kHz in
    released = run(channel, sends, 5.0)
    times = np.array([now for now, _ in released])
    assert 49 <= len(released) <= 51                   # 10 Hz over 5 s
    for start in np.arange(0.0, 4.0, 0.25):           # no window of 1 s holds more than 10 + 1
        assert np.sum((times >= start) & (times < start + 1.0)) <= 11
    for now, delivery in released:                     # each delivery is the newest message available
        newest = sends[sends <= now + 1e-12].max()
        assert delivery.stamp == pytest.approx(newest, abs=1e-9)
    assert channel.statistics().dropped["rate_cap"] > 4000


def test_same_seed_same_run_different_seed_different_run():
    def outcome(seed):
        channel = Channel(ChannelConfig(delay=0.1, jitter=0.02, drop_probability=0.3, seed=seed))
        return [(d.payload, round(d.held, 9)) for _, d in run(channel, np.arange(0.0, 1.0, 0.002), 1.5)]

    assert outcome(7) == outcome(7)
    assert outcome(7) != outcome(8)


def test_runtime_reconfiguration_applies_to_new_messages():
    channel = Channel(ChannelConfig(delay=0.2))
    channel.push("old", 0.0, 0.0)
    channel.reconfigure(delay=0.05)
    channel.push("new", 0.01, 0.01)
    # FIFO: the new message (due at 0.06) waits for the old one (due at 0.2).
    assert channel.pop_due(0.1) == []
    assert [d.payload for d in channel.pop_due(0.2)] == ["old", "new"]
    channel.push("later", 0.3, 0.3)
    assert [d.payload for d in channel.pop_due(0.35)] == ["later"]
    channel.reconfigure(drop_probability=1.0)
    assert channel.push("lost", 0.4, 0.4) is False
    channel.reconfigure(blackout_windows=((0.0, 10.0),), drop_probability=0.0)
    assert channel.push("dark", 0.5, 0.5) is False
    assert channel.config.delay == 0.05


def test_invalid_reconfiguration_is_refused_and_changes_nothing():
    channel = Channel(ChannelConfig(delay=0.2))
    with pytest.raises(FicInputError, match="delay"):
        channel.reconfigure(delay=-0.1)
    with pytest.raises(FicInputError, match="drop_probability"):
        channel.reconfigure(drop_probability=1.5)
    with pytest.raises(FicInputError, match="blackout"):
        channel.reconfigure(blackout_windows=((2.0, 1.0),))
    with pytest.raises(FicInputError, match="jitter"):
        channel.reconfigure(jitter=math.nan)
    assert channel.config == ChannelConfig(delay=0.2)


def test_queue_is_bounded():
    channel = Channel(ChannelConfig(delay=10.0, max_queue=100))
    for i in range(150):
        channel.push(i, None, i * 1e-3)
    assert len(channel) == 100 and channel.statistics().dropped["overflow"] == 50
    assert channel.pop_due(20.0)[0].payload == 50       # the oldest went first


@settings(max_examples=40, deadline=None)
@given(delay=st.floats(0.0, 0.5), jitter=st.floats(0.0, 0.1), p=st.floats(0.0, 1.0),
       seed=st.integers(0, 2 ** 31), gaps=st.lists(st.floats(0.0, 0.01), min_size=1, max_size=200))
def test_every_message_is_delivered_once_or_counted_as_dropped(delay, jitter, p, seed, gaps):
    channel = Channel(ChannelConfig(delay=delay, jitter=jitter, drop_probability=p, seed=seed))
    now = 0.0
    delivered = []
    for i, gap in enumerate(gaps):
        now += gap
        channel.push(i, now, now)
        delivered += [d.payload for d in channel.pop_due(now)]
    delivered += [d.payload for d in channel.pop_due(now + delay + jitter + 1.0)]
    stats = channel.statistics()
    assert delivered == sorted(set(delivered))          # FIFO and no duplicates
    assert len(delivered) + stats.dropped_total == len(gaps) == stats.received


def test_header_stamp_is_read_from_cdr_bytes():
    import struct

    from fic_teleop_runtime.cdr_header import header_stamp

    body = struct.pack("<iI", 1_700_000_123, 456_789_000) + struct.pack("<I", 11) + b"panda_link0\x00"
    assert header_stamp(b"\x00\x01\x00\x00" + body) == (1_700_000_123, 456_789_000)
    big = b"\x00\x00\x00\x00" + struct.pack(">iI", -3, 999_999_999)
    assert header_stamp(big) == (-3, 999_999_999)
    assert header_stamp(b"\x00\x01\x00\x00\x01\x00") is None                       # too short
    assert header_stamp(b"\x00\x07\x00\x00" + body) is None                        # not plain CDR
    assert header_stamp(b"\x00\x01\x00\x00" + struct.pack("<iI", 1, 2_000_000_000)) is None


def test_the_links_configuration_from_the_channels_parameters():
    """channel_config, for channel_node and the in-process runner: config/channel.yaml's values as the typed object
    the node declares; blackout windows and lost_from counted from the node's start or on its clock; a seed of -1
    from the OS; what a row cannot refuse alone (an odd count of bounds, an unknown time reference) refused."""
    parameters = ChannelParameters.from_values({**config_values("channel.yaml"), "routes": [], "logged_deliveries": [],
                                                "blackout_windows": [1.0, 2.0], "lost_from": 5.0})
    assert parameters.time_reference == "start" and parameters.seed == -1
    config = channel_config(parameters, origin=10.0)
    assert config.blackout_windows == ((11.0, 12.0),) and config.lost_from == 15.0 and config.seed is None
    assert config.delay == parameters.delay and config.jitter_distribution == parameters.jitter_distribution
    on_clock = channel_config(parameters.replaced({"time_reference": "clock", "seed": 3}), origin=10.0)
    assert on_clock.blackout_windows == ((1.0, 2.0),) and on_clock.lost_from == 5.0 and on_clock.seed == 3
    with pytest.raises(FicInputError, match="blackout_windows needs pairs"):
        channel_config(parameters.replaced({"blackout_windows": [1.0, 2.0, 3.0]}))
    with pytest.raises(FicInputError, match="time_reference must be 'start' or 'clock'"):
        channel_config(parameters.replaced({"time_reference": "wall"}))
