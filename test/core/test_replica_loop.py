"""The replica's loop outside ROS: the desired pose x_d = x_d' + x_d'' with its watchdog and give-back, the control
grid, the torque slew inside the controller, and the run-time swap of parameters (fic_core.replica_loop and the
modules it composes). Properties, checked on a real Pinocchio Panda model at rest (no simulator needed)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from config_values import replica_loop_parameters, replica_loop_values
from hypothesis import Phase, given, settings
from hypothesis import strategies as st

from fic_core.control_schedule import ControlSchedule
from fic_core.desired_pose import DesiredPose, DesiredPoseParameters
from fic_core.desired_velocity import DesiredVelocityFilter
from fic_core.errors import FicInputError
from fic_core.input_authority import AuthorityBounds, CommandAuthority
from fic_core.limits import PANDA_TORQUE_RATE_LIMIT, LimitFlag
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.replica_loop import ReplicaLoop
from fic_core.replica_parameters import ReplicaLoopParameters, checked
from fic_core.torque_slew import TorqueSlew

Q0 = np.array(NOMINAL_CONFIGURATION, dtype=float)
QD0 = np.zeros(7)
START = np.array([0.3, 0.0, 0.5])


def started_pose(**parameters) -> DesiredPose:
    pose = DesiredPose(DesiredPoseParameters(**parameters))
    pose.start(START, np.eye(3))
    return pose


# --- DesiredPose -----------------------------------------------------------------------------------------------
def test_the_first_planner_pose_and_the_first_command_are_approached_without_a_jump() -> None:
    """x_d starts at the start pose; a far planner pose and a far first x_d' are given back at resume_speed."""
    pose = started_pose(resume_speed=0.1, set_point_extrapolation=0.0, master_timeout=60.0)
    previous = pose.update(0.0, 0.001).position
    np.testing.assert_allclose(previous, START)
    pose.add_planner_pose(1_000_000, START + [0.2, 0.0, 0.0], np.eye(3), 0.001)
    pose.add_teleoperation(1_000_000, [0.0, 0.1, 0.0], 0.001)
    for tick in range(2, 4000):
        position = pose.update(tick * 0.001, 0.001).position
        # each of the two jumps shrinks at 0.1 m/s: x_d moves at most 2 x 0.1 m/s x 1 ms a tick
        assert np.linalg.norm(position - previous) <= 2 * 0.1 * 0.001 + 1e-12
        previous = position
    np.testing.assert_allclose(previous, START + [0.2, 0.1, 0.0], atol=1e-9)


@settings(max_examples=15, deadline=None, phases=(Phase.explicit, Phase.reuse, Phase.generate))  # no slow shrink
@given(held=st.lists(st.floats(-0.15, 0.15), min_size=3, max_size=3),
       back=st.lists(st.floats(-0.15, 0.15), min_size=3, max_size=3),
       silence=st.floats(0.6, 2.0))
def test_no_jump_of_x_d_at_a_resume(held, back, silence) -> None:
    """Commands stop (x_d' is held after master_timeout) and come back anywhere: x_d never moves faster than the
    commanded x_d' plus resume_speed, and it reaches the new command."""
    pose = started_pose(master_timeout=0.5, resume_speed=0.1, set_point_extrapolation=0.0)
    now = 0.0
    for tick in range(3000):  # x_d' given back to `held` from 0 (at most 0.26 m at 0.1 m/s)
        now = tick * 0.001
        if tick % 10 == 0:
            pose.add_teleoperation(int(round(now * 1e9)), held, now)
        pose.update(now, 0.001)
    np.testing.assert_allclose(pose.offset, held, atol=1e-9)
    notices = []
    ticks = int(silence / 0.001)
    for _ in range(ticks):
        now += 0.001
        notices += pose.update(now, 0.001).notices
    assert pose.master_stale and len(notices) == 1 and "master_timeout" in notices[0]
    np.testing.assert_allclose(pose.offset, held, atol=1e-9)   # held while stale
    now += 0.001
    assert "back" in pose.add_teleoperation(int(round(now * 1e9)), back, now)
    previous = pose.update(now, 0.001).position
    # the resume itself moves x_d by one give-back step only
    assert np.linalg.norm(previous - (START + held)) <= 0.1 * 0.001 + 1e-12
    for tick in range(1, 6000):
        now += 0.001
        if tick % 10 == 0:
            pose.add_teleoperation(int(round(now * 1e9)), back, now)
        position = pose.update(now, 0.001).position
        assert np.linalg.norm(position - previous) <= 0.1 * 0.001 + 1e-12
        previous = position
    np.testing.assert_allclose(pose.offset, back, atol=1e-9)


def test_a_command_records_its_age_at_first_use_once() -> None:
    pose = started_pose()
    pose.add_teleoperation(1_000_000_000, [0.0, 0.0, 0.0], 1.01)
    assert pose.command_unused
    pose.update(1.02, 0.001)
    assert not pose.command_unused and pose.master_stamp_used_ns == 1_000_000_000
    assert pose.master_first_use_age == pytest.approx(0.02)
    pose.update(1.05, 0.001)
    assert pose.master_first_use_age == pytest.approx(0.02)


def test_bad_set_points_change_nothing() -> None:
    pose = started_pose()
    pose.add_teleoperation(0, [0.01, 0.0, 0.0], 0.0)
    with pytest.raises(FicInputError):
        pose.add_teleoperation(1_000_000, [float("nan"), 0.0, 0.0], 0.001)
    assert pose.master_stamp_ns == 0


def test_the_feedforward_is_the_planners_while_fresh() -> None:
    pose = started_pose(offset_feedforward=False)
    pose.add_planner_pose(0, START, np.eye(3), 0.0)
    pose.add_planner_acceleration([1.0, 0.0, 0.0], 0.0)
    np.testing.assert_allclose(pose.update(0.01, 0.001).acceleration, [1.0, 0.0, 0.0])
    assert pose.update(0.2, 0.001).acceleration is None   # older than 50 ms: not fed forward


def test_the_velocity_filter_converges_to_a_ramps_speed() -> None:
    velocity_filter = DesiredVelocityFilter(0.02)
    assert velocity_filter.update([0.0, 0.0, 0.0], 0.001) is None
    for tick in range(1, 500):
        twist = velocity_filter.update([0.1 * tick * 0.001, 0.0, 0.0], 0.001)
    np.testing.assert_allclose(twist, [0.1, 0.0, 0.0, 0.0, 0.0, 0.0], atol=1e-6)
    assert DesiredVelocityFilter(0.0).update([1.0, 0.0, 0.0], 0.001) is None


# --- ControlSchedule, TorqueSlew -------------------------------------------------------------------------------
def test_the_grid_ticks_at_the_control_rate_on_joint_state_time() -> None:
    schedule = ControlSchedule(250.0, 0.001)
    ticks = [k for k in range(1000) if schedule.due(k * 0.001) and schedule.tick(k * 0.001) > 0]
    assert len(ticks) == 250 and np.all(np.diff(ticks) == 4)
    on_command = ControlSchedule(50.0, 0.001, tick_on_command=True)
    on_command.tick(0.0)
    assert not on_command.due(0.005) and on_command.due(0.005, command_unused=True)
    with pytest.raises(FicInputError):
        ControlSchedule(2000.0, 0.001)


def test_a_skipped_state_gives_the_real_interval_and_a_stall_one_period() -> None:
    schedule = ControlSchedule(1000.0, 0.001)
    schedule.tick(0.0)
    assert schedule.tick(0.003) == pytest.approx(0.003)
    assert schedule.tick(1.0) == pytest.approx(0.001)


@settings(max_examples=50, deadline=None)
@given(targets=st.lists(st.lists(st.floats(-80.0, 80.0), min_size=7, max_size=7), min_size=2, max_size=30),
       gaps=st.lists(st.one_of(st.none(), st.floats(0.0, 0.01)), min_size=30, max_size=30))
def test_the_slew_bounds_every_step_of_any_sequence(targets, gaps) -> None:
    """|tau_k - tau_(k-1)| <= rate * dt_k for any targets and times (dt_k: the interval the slew took, at least
    one command period; an unknown time counts as one command period)."""
    slew = TorqueSlew(PANDA_TORQUE_RATE_LIMIT, 0.001)
    time = 0.0
    previous = None
    for target, gap in zip(targets, gaps):
        stamp = None if gap is None else time + gap
        interval = slew.interval(stamp)
        sent = slew.step(np.array(target), stamp)
        if previous is not None:
            assert np.abs(sent - previous).max() <= PANDA_TORQUE_RATE_LIMIT * interval + 1e-9
            assert interval >= 0.001
        if stamp is not None:
            time = stamp
        previous = sent


# --- ReplicaLoop --------------------------------------------------------------------------------------------------
def run_loop(loop: ReplicaLoop, states: int, start: float = 0.0, offset=None) -> list:
    steps = []
    for k in range(states):
        time = start + k * 0.001
        if offset is not None and k % 10 == 0:
            loop.add_teleoperation(int(round(time * 1e9)), offset, time)
        steps.append(loop.joint_state(time, time, Q0, QD0))
    return steps


@pytest.mark.parametrize("control_rate", [1000.0, 250.0])
def test_the_sent_torque_is_what_the_limit_status_describes(control_rate) -> None:
    """Lockstep (every state answered), a 10 cm step of x_d' and a hot swap of the controller in the middle: every
    torque sent is within rate x 1 ms of the one before (the slew is inside the controller), and the torque-rate
    ratio the LimitStatus reports is of that torque, so it never exceeds 1."""
    loop = ReplicaLoop(replica_loop_parameters(control_rate=control_rate, answer_every_state=True))
    steps = run_loop(loop, 300, offset=[0.1, 0.0, 0.0])
    loop.configure({"controller": "linear", "translation_stiffness": 2000.0})
    steps += run_loop(loop, 300, start=0.3, offset=[-0.1, 0.0, 0.0])
    sent = np.array([step.torque for step in steps])
    assert len(sent) == 600                                   # every state answered
    assert np.abs(np.diff(sent, axis=0)).max() <= PANDA_TORQUE_RATE_LIMIT * 0.001 + 1e-9
    commands = [step.command for step in steps if step.command is not None]
    assert len(commands) == (600 if control_rate == 1000.0 else 150)
    assert max(c.torque_rate_ratio.max() for c in commands) <= 1.0 + 1e-9
    assert not any(c.limit_violations & LimitFlag.TORQUE_RATE for c in commands)
    assert loop.controller.ticks == len(commands)            # counters carried over the swap
    for command, step in zip(commands, [s for s in steps if s.command is not None]):
        np.testing.assert_array_equal(command.torque, step.torque)


def test_between_ticks_realtime_sends_nothing_and_lets_states_be_skipped() -> None:
    loop = ReplicaLoop(replica_loop_parameters(control_rate=250.0))
    steps = run_loop(loop, 8)
    assert [step.torque is not None for step in steps] == [True, False, False, False] * 2
    assert loop.skips(0.006) and not loop.skips(0.008)
    assert loop.refuse_joint_state() is not None and loop.counts["rejected_joint_states"] == 1


def test_status_and_pose_gates_and_or_ed_flags() -> None:
    loop = ReplicaLoop(replica_loop_parameters(status_rate=100.0, pose_rate=50.0))
    steps = run_loop(loop, 100)
    assert sum(step.status_due for step in steps) == 10 and sum(step.poses_due for step in steps) == 5
    assert loop.take_limit_flags() == (int(LimitFlag.NONE), int(LimitFlag.NONE))


def _command(loop: ReplicaLoop, now: float, offset) -> tuple:
    return loop.teleoperation_command(int(round(now * 1e9)), now, mode=0, haptic_gain=0.5, workspace_scale=1.0,
                                      velocity_gain=2.0, handle_position=(0.0, 0.0, 0.0), desired_offset=offset)


@pytest.mark.parametrize("silence", [0.0, 0.8])
def test_the_authority_forgets_its_last_command_at_a_resume_only(silence: float) -> None:
    """A command 0.3 m from the last one: in a stream, the authority's rate bound (1 m/s, 0.05 m burst) lets x_d'
    move by the burst and 1 m/s of the 10 ms since; after a loss (master_timeout 0.5 s passed, the watchdog
    stale) it is accepted whole, since DesiredPose gives the jump back at resume_speed (0.1 m/s) instead."""
    loop = ReplicaLoop(replica_loop_parameters(master_timeout=0.5, answer_every_state=True),
                       authority=CommandAuthority(AuthorityBounds(max_offset_speed=1.0, max_offset_burst=0.05)))
    now = 0.0
    for tick in range(300 + int(silence * 1000)):
        now = tick * 0.001
        if tick % 10 == 0 and tick < 300:
            verdict, _ = _command(loop, now, (0.0, 0.0, 0.0))
            assert verdict.accepted and not verdict.rate_limited
        loop.joint_state(now, now, Q0, QD0)
    assert loop.desired.master_stale == (silence > 0.0)
    now += 0.01
    verdict, notice = _command(loop, now, (0.3, 0.0, 0.0))
    assert verdict.accepted
    if silence:
        assert not verdict.rate_limited and verdict.offset[0] == 0.3 and "back" in notice
    else:
        assert verdict.rate_limited and verdict.offset[0] == pytest.approx(0.05, abs=1e-9) and notice is None
    assert loop.counts["rejected_teleop_commands"] == 0


def test_a_refused_command_is_counted_and_changes_nothing() -> None:
    loop = ReplicaLoop(replica_loop_parameters(answer_every_state=True))
    loop.joint_state(0.0, 0.0, Q0, QD0)
    verdict, notice = _command(loop, 0.001, (math.nan, 0.0, 0.0))
    assert not verdict.accepted and notice is None and loop.authority.refused == 1
    assert loop.counts["rejected_teleop_commands"] == 1 and loop.desired.master_received is None


def test_a_bad_parameter_changes_nothing() -> None:
    loop = ReplicaLoop(replica_loop_parameters())
    controller = loop.controller
    with pytest.raises(FicInputError, match="translation_stiffness"):
        loop.configure({"translation_stiffness": -1.0})
    with pytest.raises(FicInputError, match="control_rate"):
        loop.configure({"control_rate": 1000.0, "command_period": 0.01})
    with pytest.raises(FicInputError, match="^controller must be one of"):
        loop.configure({"controller": "pid"})
    with pytest.raises(FicInputError, match="^unknown replica parameter 'translation_stifness'; did you mean "
                                            "'translation_stiffness'"):
        loop.configure({"translation_stifness": 1.0})
    with pytest.raises(FicInputError, match="missing: translation_stiffness"):
        ReplicaLoopParameters.from_values({name: value for name, value in replica_loop_values().items()
                                           if name != "translation_stiffness"})
    assert loop.controller is controller and loop.parameters == checked(replica_loop_parameters())
    assert loop.configure({"translation_stiffness": 300}).translation_stiffness == 300.0   # a float, as checked
    assert loop.parameters.translation_stiffness == 300.0 and loop.controller is not controller


def test_the_paper_law_switches_off_the_terms_beyond_eq_7() -> None:
    """paper_law: the planner and offset feedforward and the joint friction compensation are off whatever their own
    rows say, in the loop's parameters and in the controller built from them."""
    beyond = {"planner_feedforward": True, "offset_feedforward": True, "joint_damping_compensation": True}
    loop = ReplicaLoop(replica_loop_parameters(paper_law=True, **beyond))
    p = loop.parameters
    assert not (p.planner_feedforward or p.offset_feedforward or p.joint_damping_compensation)
    assert not loop.controller.joint_damping_compensation and not loop.desired.parameters.planner_feedforward
    assert ReplicaLoop(replica_loop_parameters(paper_law=False, **beyond)).parameters.offset_feedforward


@pytest.mark.parametrize("position, quaternion", [((math.nan, 0.0, 0.5), (0.0, 0.0, 0.0, 1.0)),
                                                  ((0.3, 0.0, 0.5), (0.0, 0.0, 0.0, 0.0)),
                                                  ((0.3, 0.0), (0.0, 0.0, 0.0, 1.0))])
def test_a_refused_planner_pose_is_counted_as_refused_and_changes_nothing(position, quaternion) -> None:
    """A planner pose with a non-finite or short position, or a zero quaternion, is refused in one line
    (FicInputError), counted under rejected_planner_poses and not as received, and x_d stays where it was."""
    loop = ReplicaLoop(replica_loop_parameters(answer_every_state=True))
    loop.joint_state(0.0, 0.0, Q0, QD0)
    before = loop.desired.update(0.001, 0.001).position.copy()
    with pytest.raises(FicInputError):
        loop.add_planner_pose(1_000_000, position, quaternion, 0.001)
    assert loop.counts["rejected_planner_poses"] == 1 and loop.counts["planner_poses"] == 0
    np.testing.assert_array_equal(loop.desired.update(0.002, 0.001).position, before)
    loop.add_planner_pose(2_000_000, before, (0.0, 0.0, 0.0, 1.0), 0.002)
    assert loop.counts["rejected_planner_poses"] == 1 and loop.counts["planner_poses"] == 1


def test_a_refused_teleoperation_offset_is_counted_as_refused() -> None:
    """x_d' with a non-finite entry, given straight to add_teleoperation: refused, counted as refused only."""
    loop = ReplicaLoop(replica_loop_parameters(answer_every_state=True))
    loop.joint_state(0.0, 0.0, Q0, QD0)
    with pytest.raises(FicInputError):
        loop.add_teleoperation(1_000_000, (0.0, math.inf, 0.0), 0.001)
    assert loop.counts["rejected_teleop_commands"] == 1 and loop.counts["teleop_commands"] == 0
    assert loop.desired.master_received is None


def test_a_control_step_that_refuses_its_inputs_is_counted_said_and_held(monkeypatch) -> None:
    """The controller refusing what the loop hands it (only a bug upstream could cause it): the tick holds instead
    (the same law toward the held pose), counts a controller error, and says why at the error level."""
    loop = ReplicaLoop(replica_loop_parameters(answer_every_state=True))
    loop.joint_state(0.0, 0.0, Q0, QD0)
    held = loop.controller.hold(Q0, QD0)

    law = loop.controller.command
    calls = []

    def refuse_once(*args, **kwargs):   # the hold then runs the law itself, toward the held pose
        calls.append(args)
        if len(calls) == 1:
            raise FicInputError("desired_position has a NaN")
        return law(*args, **kwargs)
    monkeypatch.setattr(loop.controller, "command", refuse_once)
    step = loop.joint_state(0.001, 0.001, Q0, QD0)
    assert loop.counts["controller_errors"] == 1
    assert any(level == "error" and "refused its inputs" in text for level, text in step.notices)
    assert step.command is not None and np.all(np.isfinite(step.command.torque))
    assert len(calls) == 2
    np.testing.assert_allclose(step.command.torque, held.torque, atol=1e-6)
