"""x_d' rebuilt between link samples (fic_core.link_hold) and through the replica's DesiredPose: the feedforward acts
over the whole interval at any link rate, the rate is learned, and a lost or late sample never runs away."""
import numpy as np
import pytest

from fic_core.desired_pose import DesiredPose, DesiredPoseParameters
from fic_core.errors import FicInputError
from fic_core.link_hold import HOLD_DESIGNS, LinkHold

CONTROL_PERIOD = 0.002   # the replica's 500 Hz realtime tick
DELAY = 0.2


def sinusoid(t: float, frequency: float = 0.7, amplitude: float = 0.02) -> list[float]:
    return [amplitude * np.sin(2 * np.pi * frequency * t), 0.5 * amplitude * np.cos(2 * np.pi * frequency * t), 0.0]


def drive_desired_pose(link_rate: float, duration: float = 12.0, jitter: float = 0.0, seed: int = 0,
                       frequency: float = 0.7) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The replica's x_d' path and fed-forward acceleration at each 500 Hz tick, for a sinusoidal offset the master
    samples at 100 Hz and the link delivers at ``link_rate`` (every N-th sample, DELAY late, +- ``jitter``)."""
    rng = np.random.default_rng(seed)
    pose = DesiredPose(DesiredPoseParameters(planner_feedforward=False))
    pose.start(np.zeros(3), np.eye(3))
    every = max(1, round(100.0 / link_rate))
    arrivals = []
    for k in range(int(duration * 100)):
        if k % every == 0:
            stamp = k * 0.01
            arrivals.append((stamp + DELAY + rng.uniform(0.0, jitter), stamp))
    arrivals.sort()
    times, positions, accelerations = [], [], []
    next_arrival = 0
    now = 0.0
    while now < duration + DELAY:
        while next_arrival < len(arrivals) and arrivals[next_arrival][0] <= now:
            received, stamp = arrivals[next_arrival]
            pose.add_teleoperation(int(round(stamp * 1e9)), sinusoid(stamp, frequency), received)
            next_arrival += 1
        if next_arrival:
            sample = pose.update(now, CONTROL_PERIOD)
            times.append(now)
            positions.append(sample.position)
            accelerations.append(np.zeros(3) if sample.acceleration is None else sample.acceleration)
        now += CONTROL_PERIOD
    return np.array(times), np.array(positions), np.array(accelerations)


@pytest.mark.parametrize("link_rate", [100.0, 10.0, 5.0])
def test_the_offset_feedforward_acts_on_at_least_90_percent_of_ticks_at_any_link_rate(link_rate):
    times, _, accelerations = drive_desired_pose(link_rate, jitter=0.004)
    settled = times > DELAY + 1.0
    acting = np.linalg.norm(accelerations[settled], axis=1) > 0.0
    # The hold this replaced stopped its feedforward 15 ms after each sample: 7.5 % of the ticks at 10 Hz.
    assert acting.mean() >= 0.90


@pytest.mark.parametrize("frequency", [0.3, 0.6, 1.0])
def test_the_fed_forward_acceleration_is_the_acceleration_of_the_path_x_d_follows_at_10_hz(frequency):
    """Amplitude within 15 % and phase within 10 degrees of x_d''s own acceleration (-w^2 x about its mean), fitted
    as sinusoids: a feedforward that lags its path pushes along the velocity near the arm's resonance."""
    times, positions, accelerations = drive_desired_pose(10.0, duration=16.0, frequency=frequency)
    keep = times > 2.0
    omega = 2 * np.pi * frequency
    basis = np.c_[np.sin(omega * times[keep]), np.cos(omega * times[keep]), np.ones(keep.sum())]
    path = np.linalg.lstsq(basis, positions[keep, 0], rcond=None)[0]
    fed = np.linalg.lstsq(basis, accelerations[keep, 0], rcond=None)[0]
    path_acceleration = -omega ** 2 * path[:2]
    ratio = np.hypot(*fed[:2]) / np.hypot(*path_acceleration)
    phase = np.degrees(np.arctan2(fed[1], fed[0]) - np.arctan2(path_acceleration[1], path_acceleration[0]))
    phase = (phase + 180.0) % 360.0 - 180.0
    assert 0.85 <= ratio <= 1.15
    assert abs(phase) <= 10.0


@pytest.mark.parametrize("rate", [1000.0, 100.0, 10.0, 5.0])
def test_the_sample_interval_is_learned_from_the_stamps(rate):
    hold = LinkHold()
    interval = 1.0 / rate
    for k in range(20):
        hold.add(k * interval, [k * 0.001, 0.0, 0.0], k * interval + 0.3)
    assert hold.interval.value == pytest.approx(interval)


def test_one_lost_sample_does_not_change_the_learned_interval():
    hold = LinkHold()
    for k in [0, 1, 2, 3, 5, 6, 7, 8, 9]:
        hold.add(k * 0.1, [0.0, 0.0, 0.0], k * 0.1)
    assert hold.interval.value == pytest.approx(0.1)


def test_an_interval_first_learned_from_a_burst_is_learned_again_and_the_feedforward_acts():
    """The master's first commands 0.8 ms apart, then its 100 Hz: the 10 ms intervals are a new rate after three of
    them, not gaps for ever (which kept the offset feedforward off for whole main jobs)."""
    hold = LinkHold()
    acceleration = 0.4   # [m/s^2] along x: x = a t^2 / 2
    stamps = [0.0, 0.0008, 0.0016] + [0.0016 + 0.01 * k for k in range(1, 40)]
    for stamp in stamps:
        hold.add(stamp, [0.5 * acceleration * stamp ** 2, 0.0, 0.0], stamp + 0.2)
    assert hold.interval.value == pytest.approx(0.01)
    assert hold.acceleration(stamps[-1] + 0.2 + 0.001)[0] == pytest.approx(acceleration, rel=0.05)


def test_a_link_that_slows_down_is_learned_at_its_new_rate():
    hold = LinkHold()
    stamps = [0.01 * k for k in range(20)] + [0.19 + 0.1 * k for k in range(1, 10)]
    for stamp in stamps:
        hold.add(stamp, [0.0, 0.0, 0.0], stamp)
    assert hold.interval.value == pytest.approx(0.1)


@pytest.mark.parametrize("outage", [0.05, 0.2, 1.0])
def test_a_blackout_between_samples_at_the_old_rate_stays_a_gap(outage):
    hold = LinkHold()
    stamps = [0.01 * k for k in range(20)] + [0.19 + outage + 0.01 * k for k in range(10)]
    for stamp in stamps:
        hold.add(stamp, [0.0, 0.0, 0.0], stamp)
    assert hold.interval.value == pytest.approx(0.01)


@pytest.mark.parametrize("design", HOLD_DESIGNS)
def test_a_stream_that_stops_leaves_the_hold_still_near_the_newest_sample(design):
    hold = LinkHold(design)
    for k in range(10):   # 0.5 m/s along x at 10 Hz, then nothing
        hold.add(k * 0.1, [0.05 * k, 0.0, 0.0], k * 0.1)
    newest = 0.45
    for now in (1.0, 2.0, 60.0):
        position = hold.position(now)
        assert np.all(np.isfinite(position))
        # interpolate: at the newest sample; extrapolate: at most one interval beyond it along its slope.
        beyond = 0.0 if design == "interpolate" else 0.05 + 1e-12
        assert newest - 1e-12 <= position[0] <= newest + beyond
        assert not hold.velocity(now).any() and not hold.acceleration(now).any()


def test_interpolation_never_leaves_the_segment_between_two_samples():
    rng = np.random.default_rng(3)
    hold = LinkHold("interpolate", max_speed=100.0)
    samples = rng.uniform(-0.05, 0.05, size=(40, 3))
    for k, sample in enumerate(samples):
        hold.add(k * 0.1, sample, k * 0.1 + rng.uniform(0.0, 0.01))
        if k:
            low = np.minimum(samples[:k + 1].min(axis=0), sample)
            high = np.maximum(samples[:k + 1].max(axis=0), sample)
            for now in np.linspace(k * 0.1, k * 0.1 + 0.2, 11):
                position = hold.position(now)
                assert np.all(position >= low - 1e-12) and np.all(position <= high + 1e-12)


def test_a_gap_restarts_the_estimates_and_the_catch_up_is_bounded_by_max_speed():
    hold = LinkHold(max_speed=0.5)
    for k in range(10):
        hold.add(k * 0.1, [0.01 * k, 0.0, 0.0], k * 0.1)
    hold.add(3.0, [0.5, 0.0, 0.0], 3.0)   # 2.1 s later, 0.41 m away
    assert not hold.acceleration(3.001).any()
    assert np.linalg.norm(hold.velocity(3.001)) <= 0.5 + 1e-12
    assert hold.position(3.0 + 0.41 / 0.5 + 1e-6)[0] == pytest.approx(0.5)


def test_bad_samples_are_refused_and_change_nothing():
    hold = LinkHold()
    hold.add(0.0, [0.0, 0.0, 0.0], 0.0)
    hold.add(0.1, [0.01, 0.0, 0.0], 0.1)
    before = hold.position(0.15)
    for stamp, position in ((0.2, [np.nan, 0.0, 0.0]), (np.inf, [0.0, 0.0, 0.0]), (0.2, [0.0, 0.0])):
        with pytest.raises(FicInputError):
            hold.add(stamp, position, 0.2)
    assert np.array_equal(hold.position(0.15), before)
    with pytest.raises(FicInputError):
        LinkHold("spline")


def test_a_sample_too_large_for_a_float_difference_is_a_step_at_rest():
    hold = LinkHold()
    hold.add(0.0, [-1e308, 0.0, 0.0], 0.0)
    hold.add(0.1, [1e308, 0.0, 0.0], 0.1)
    assert hold.position(0.2)[0] == 1e308
    assert not hold.velocity(0.2).any() and not hold.acceleration(0.2).any()


def test_switching_the_design_live_does_not_jump_x_d():
    pose = DesiredPose(DesiredPoseParameters())
    pose.start(np.zeros(3), np.eye(3))
    now = 0.0
    previous = None
    for k in range(400):
        now = k * CONTROL_PERIOD
        if k % 50 == 0:
            pose.add_teleoperation(int(round(now * 1e9)), sinusoid(now), now + DELAY)
        if k == 200:
            pose.parameters = DesiredPoseParameters(interpolate_link_samples=False)
        if k * CONTROL_PERIOD >= DELAY:
            position = pose.update(now + DELAY, CONTROL_PERIOD).position
            if previous is not None:
                assert np.linalg.norm(position - previous) < 0.002   # 1 m/s at most between ticks
            previous = position
