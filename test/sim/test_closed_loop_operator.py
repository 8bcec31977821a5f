"""The closed-loop E1 operator (sim_bridge/device/closed_loop_operator.py) on a synthetic replica: what it sees comes
through a delayed channel, it reacts a reaction time later, and it times its moves from the seen circle."""
from __future__ import annotations

import math

import numpy as np
import pytest

from sim_bridge.channel.channel import Channel, ChannelConfig
from sim_bridge.device.closed_loop_operator import ClosedLoopOperator, ClosedLoopParameters, Frame
from sim_bridge.device.virtual_operator import Hand

CENTRE = np.array([0.45, 0.0, 0.35])
RADIUS = 0.10
OMEGA = 2.0 * math.pi / 5.0          # the paper's 5 s lap
FRAME_EVERY, TICK_EVERY = 32, 4      # [ms] a 31 Hz camera, the 250 Hz device
PUSHABLE_ON_PATH = np.array([0.45, -0.10, 0.235])


def watch(angle_of_time, delay: float, duration: float, reaction: float = 0.25, pushable_of_time=None):
    """Feed the operator frames of a TCP at ``angle_of_time(t)`` on the circle, plus the offset the operator's hand
    asked for one delay and one handle lag before, through a channel of ``delay``; the hand holds the handle
    still at the origin. Returns (tick times, hand forces (n, 3), operator)."""
    operator = ClosedLoopOperator(ClosedLoopParameters(reaction_time=reaction, assumed_one_way_delay=delay))
    video = Channel(ChannelConfig(delay=delay, seed=3))
    hand = Hand()
    times, forces, targets = [], [], []
    for ms in range(0, int(round(duration * 1000)), TICK_EVERY):
        now = ms * 1e-3
        if ms % FRAME_EVERY == 0:
            angle = angle_of_time(now)
            followed = int(np.searchsorted(times, now - delay - operator.parameters.handle_lag, side="right")) - 1
            offset = targets[followed] if followed >= 0 else np.zeros(3)
            tcp = CENTRE + RADIUS * np.array([math.cos(angle), math.sin(angle), 0.0]) + offset
            pushable = PUSHABLE_ON_PATH if pushable_of_time is None else pushable_of_time(now)
            video.push(Frame(now, tcp, pushable), now, now)
        if ms % TICK_EVERY == 0:
            for delivery in video.pop_due(now):
                operator.see(now, delivery.payload)
            targets.append(operator.target(now))
            hand.update(targets[-1], np.zeros(3), TICK_EVERY * 1e-3)
            times.append(now)
            forces.append(hand.force(np.zeros(3), np.zeros(3)))
    return np.array(times), np.array(forces), operator


@pytest.mark.parametrize("delay", [0.2, 1.0])
def test_a_step_in_the_seen_pose_moves_the_hand_after_the_channel_delay_plus_the_reaction_time(delay):
    # The robot circles slowly (20 deg/s) away from both obstacles (the fixed one at 90 deg, the pushable at 270),
    # from -80 deg to -20 deg at t_step; then it is seen jumped ahead to where the fixed obstacle's passing, predicted
    # from the seen angle, falls half a second before the end of the avoid move's hold as the operator aims.
    step_time, speed = 3.0, math.radians(20.0)
    p = ClosedLoopParameters()
    horizon = 2.0 * delay + p.reaction_time + p.handle_lag          # from a capture to where the operator aims
    jumped = math.radians(90.0) - speed * (horizon + 0.5)

    def angle(t):
        return speed * (t - step_time) + (jumped if t >= step_time else math.radians(-20.0))

    times, forces, _ = watch(angle, delay, step_time + delay + 1.0)
    moved = times[np.linalg.norm(forces, axis=1) > 0.0]
    assert moved.size, "the hand never moved"
    latency = moved[0] - step_time
    # A frame every 32 ms: the first frame after the step may come up to one frame later.
    assert delay + 0.25 <= latency <= delay + 0.25 + FRAME_EVERY * 1e-3 + 1e-9

    _, still, _ = watch(lambda t: speed * (t - step_time) - math.radians(20.0), delay, step_time + delay + 1.0)
    assert not np.any(np.linalg.norm(still, axis=1) > 0.0), "without the step the hand should have stayed"


@pytest.mark.parametrize("delay", [0.2, 1.0, 2.0])
def test_the_avoid_move_is_timed_for_the_passing_it_predicts_from_the_delayed_video(delay):
    # The robot starts circling at t = 1.8 s from angle 0, as the E1 planner does; the fixed obstacle is at 90 deg.
    def angle(t):
        return OMEGA * max(t - 1.8, 0.0)

    _, _, operator = watch(angle, delay, 15.0)
    avoids = [(start, passing) for name, start, passing in operator.moves_started if name == "avoid"]
    true_passings = 1.8 + (0.25 + np.arange(4)) * 5.0      # the robot at 90 deg
    later_laps = [(start, passing) for start, passing in avoids if passing > true_passings[0] + 1.0]
    assert len(later_laps) >= 2, avoids
    p = operator.parameters
    for start, passing in later_laps:
        assert np.min(np.abs(true_passings - passing)) < 0.02          # the passing it predicts is the real one
        # It starts the move so that the offset reaches the replica when the move's shape asks for it.
        lead = p.assumed_one_way_delay + p.handle_lag + p.avoid_early + p.hold + p.ramp
        assert start == pytest.approx(passing - lead, abs=TICK_EVERY * 1e-3 + 1e-9)


def test_it_sweeps_the_pushable_obstacle_until_it_is_seen_off_the_path():
    def angle(t):
        return OMEGA * max(t - 1.8, 0.0)

    on_path = watch(angle, 0.5, 20.0)[2]
    assert sum(name == "push" for name, _, _ in on_path.moves_started) >= 3   # every lap: never seen moved

    def pushed(t):   # pushed 0.10 m outward at 6 s (the first sweep), seen half a second later
        return PUSHABLE_ON_PATH + (np.array([0.0, -0.10, 0.0]) if t >= 6.0 else 0.0)

    cleared = watch(angle, 0.5, 20.0, pushable_of_time=pushed)[2]
    assert [name for name, _, _ in cleared.moves_started].count("push") == 1


def test_refuses_bad_parameters_and_frames():
    with pytest.raises(ValueError):
        ClosedLoopParameters(reaction_time=-0.1)
    operator = ClosedLoopOperator()
    with pytest.raises(ValueError):
        operator.see(0.0, Frame(0.0, np.array([np.nan, 0.0, 0.0]), PUSHABLE_ON_PATH))
