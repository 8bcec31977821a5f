"""The offset feedforward waits out a contact's echo (fic_core.offset_feedforward_gate), when its switch is on: off from
a contact until the arm has been free for a round trip of the link plus the settle time, the planner's feedforward
untouched, a refused F/T reading taken as contact; with the switch off (the default) contact changes nothing."""
import math

import numpy as np
import pytest
from config_values import config_values
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.desired_pose import DesiredPose, DesiredPoseParameters
from fic_core.errors import FicInputError
from fic_core.offset_feedforward_gate import OffsetFeedforwardGate
from fic_core.replica_station import ReplicaParameters, ReplicaStation

PERIOD = 0.002


def test_the_gate_closes_at_a_contact_and_opens_a_round_trip_plus_settle_after_the_last_one():
    gate = OffsetFeedforwardGate(contact_force=1.0, settle=0.5)
    assert gate.update(0.0, 0.0, one_way_delay=1.0)            # never in contact: open
    assert not gate.update(1.0, 1.0, one_way_delay=1.0)        # at the threshold: contact
    assert not gate.update(2.0, 0.2, one_way_delay=1.0)        # free, but the echo is still coming
    assert not gate.update(3.49, 0.2, one_way_delay=1.0)
    assert gate.update(3.5, 0.2, one_way_delay=1.0)            # 2 x 1 s + 0.5 s after the contact
    assert not gate.update(3.6, 5.0, one_way_delay=1.0)        # a new contact starts the wait again
    assert gate.update(4.11, 0.0, one_way_delay=0.0)           # no delay measured: the settle time alone
    gate.reset()
    assert gate.update(4.2, 0.0, one_way_delay=1.0)   # the contacts forgotten


@pytest.mark.parametrize("reading", [math.inf, math.nan])
def test_an_unusable_reading_is_taken_as_contact(reading):
    gate = OffsetFeedforwardGate(contact_force=1.0, settle=0.5)
    assert not gate.update(10.0, reading, one_way_delay=0.2)
    assert gate.update(10.9, 0.0, one_way_delay=0.2)


# No deadline (a loaded machine once took 388 ms for an example that takes 0.02 ms), derandomized as the suite's
# other properties are.
@settings(max_examples=100, deadline=None, derandomize=True)
@given(st.lists(st.tuples(st.floats(0.0, 5.0), st.floats(0.0, 3.0)), min_size=1, max_size=40),
       st.floats(0.0, 2.0), st.floats(0.0, 1.0))
def test_the_gate_is_open_exactly_when_no_contact_came_within_the_wait(steps, delay, settle):
    """Against its definition: open at t iff no reading >= the threshold at a tick within 2 delay + settle before t."""
    gate = OffsetFeedforwardGate(contact_force=1.0, settle=settle)
    now, contacts = 0.0, []
    for gap, force in steps:
        now += gap
        if force >= 1.0:
            contacts.append(now)
        expected = not any(now - t < 2.0 * delay + settle for t in contacts)
        assert gate.update(now, force, one_way_delay=delay) is expected


@pytest.mark.parametrize(("contact", "settle"), [(0.0, 0.5), (-1.0, 0.5), (1.0, -0.1), (math.nan, 0.5)])
def test_bad_settings_are_refused(contact, settle):
    with pytest.raises(FicInputError):
        OffsetFeedforwardGate(contact, settle)
    with pytest.raises(FicInputError):
        DesiredPoseParameters(offset_feedforward_contact_force=contact, offset_feedforward_settle=settle)


def _offset_accelerations(contact_at: float | None, planner_acceleration: list[float] | None = None,
                          delay: float = 0.2, gate: bool = True, measured: bool = True
                          ) -> tuple[np.ndarray, np.ndarray]:
    """(times, fed-forward a_d) at each 500 Hz tick of a 0.7 Hz, 20 mm offset sent at 100 Hz and received ``delay``
    late, with one 50 ms contact of 20 N at ``contact_at`` (None: none); ``measured`` False: no F/T reading at all."""
    pose = DesiredPose(DesiredPoseParameters(planner_feedforward=planner_acceleration is not None,
                                             offset_feedforward_contact_gate=gate))
    pose.start(np.zeros(3), np.eye(3))
    times, out = [], []
    for tick in range(3000):
        now = tick * PERIOD
        if tick % 5 == 0 and now >= delay:
            stamp = now - delay
            pose.add_teleoperation(int(round(stamp * 1e9)), [0.02 * math.sin(2 * math.pi * 0.7 * stamp), 0.0, 0.0],
                                   now)
            if planner_acceleration is not None:
                pose.add_planner_pose(int(round(now * 1e9)), [0.4, 0.0, 0.4], np.eye(3), now)
                pose.add_planner_acceleration(planner_acceleration, now)
        in_contact = contact_at is not None and contact_at <= now < contact_at + 0.05
        if measured:
            pose.measure_contact_force(20.0 if in_contact else 0.3)
        sample = pose.update(now, PERIOD)
        times.append(now)
        out.append(np.zeros(3) if sample.acceleration is None else sample.acceleration)
    return np.array(times), np.array(out)


def test_the_offset_feedforward_is_off_through_the_contacts_echo_and_as_before_after_it():
    times, free = _offset_accelerations(None)
    _, touched = _offset_accelerations(2.0)
    # The measured age of a command: the 0.2 s delay and up to one 10 ms sample interval of the hold.
    waiting = (times >= 2.0) & (times < 2.94)   # the last contact tick 2.048 s + 2 x 0.2 s + 0.5 s
    after = times >= 2.05 + 2 * 0.22 + 0.5
    assert np.abs(free[waiting]).max() > 0.05      # the offset is accelerating there
    assert not touched[waiting].any()
    np.testing.assert_array_equal(touched[after], free[after])
    np.testing.assert_array_equal(touched[times < 2.0], free[times < 2.0])


def test_without_the_switch_a_contact_changes_nothing_and_the_switch_is_off_by_default():
    times, free = _offset_accelerations(None, gate=False)
    _, touched = _offset_accelerations(2.0, gate=False)
    np.testing.assert_array_equal(touched, free)
    assert DesiredPoseParameters().offset_feedforward_contact_gate is False
    assert config_values("replica.yaml")["offset_feedforward_contact_gate"] is False


def test_before_any_reading_there_was_no_contact():
    """A replica whose F/T has said nothing yet (its contact force is 0 N until measured) feeds the offset forward
    with the switch on as with it off."""
    assert DesiredPose(DesiredPoseParameters(offset_feedforward_contact_gate=True)).contact_force == 0.0
    times, unmeasured = _offset_accelerations(None, measured=False)
    _, without_gate = _offset_accelerations(None, gate=False, measured=False)
    assert np.abs(unmeasured).max() > 0.05
    np.testing.assert_array_equal(unmeasured, without_gate)


def test_the_planners_feedforward_goes_on_through_a_contact():
    times, touched = _offset_accelerations(2.0, planner_acceleration=[0.0, 0.3, 0.0])
    waiting = (times >= 2.0) & (times < 2.9)
    np.testing.assert_allclose(touched[waiting], np.tile([0.0, 0.3, 0.0], (int(waiting.sum()), 1)), atol=1e-12)


def test_the_station_hands_the_measured_force_on_and_a_refused_reading_as_contact():
    values = {**config_values("replica.yaml"), "control_rate": 500.0, "command_period": PERIOD,
              "exchanged_energy_observer": False}
    replica = ReplicaStation(ReplicaParameters.from_values(values))
    replica.wrench(replica.base_frame, [0.0, 3.0, 4.0], [0.0, 0.0, 0.0])
    assert replica.loop.desired.contact_force == pytest.approx(5.0)
    replica.wrench(replica.base_frame, [0.5, 0.0, 0.0], [0.0, 0.0, 0.0])
    assert replica.loop.desired.contact_force == pytest.approx(0.5)
    replica.wrench("tool0", [0.5, 0.0, 0.0], [0.0, 0.0, 0.0])      # not the declared frame: refused
    assert replica.loop.desired.contact_force == math.inf
