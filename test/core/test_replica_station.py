"""The replica station outside ROS (fic_core.replica_station): the input guarding on plain values (one writer per
guarded stream, joint-state stamps, the teleoperation topic's writers, the set-points after a safe hold), the F/T
reading through the driver's frame, the driver's command with the state stamp it was computed on, and the loop's
own hold and resume as the station passes them on."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from config_values import config_values

from fic_core.errors import FicInputError
from fic_core.input_authority import AUTHORITY_PARAMETERS
from fic_core.panda_description import ARM_JOINT_NAMES, NOMINAL_CONFIGURATION
from fic_core.replica_parameters import REPLICA_LOOP_PARAMETERS
from fic_core.replica_station import (
    CHANNEL_STREAMS,
    REPLICA_PARAMETERS,
    ROBOT_STREAMS,
    SET_POINT_STREAMS,
    ReplicaParameters,
    ReplicaStation,
    stream_owner,
)

Q0 = np.array(NOMINAL_CONFIGURATION, dtype=float)
QD0 = np.zeros(7)
PERIOD = 0.002


def station(**changes) -> ReplicaStation:
    values = {**config_values("replica.yaml"), "control_rate": 500.0, "command_period": PERIOD,
              "exchanged_energy_observer": False, **changes}
    return ReplicaStation(ReplicaParameters.from_values(values))


def test_the_parameters_are_one_typed_object_of_the_replicas_table() -> None:
    """ReplicaParameters: one field a row of the table the node declares (loop, driver, input authority, channel
    port), each value checked; a misspelt name is refused in one line naming the nearest row."""
    values = config_values("replica.yaml")
    parameters = ReplicaParameters.from_values(values)
    assert set(REPLICA_PARAMETERS) == set(values)                      # config/replica.yaml gives every row
    assert parameters.translation_stiffness == values["translation_stiffness"]
    assert parameters.wrench_frame_ids == values["wrench_frame_ids"] and parameters.controller == values["controller"]
    with pytest.raises(FicInputError, match=r"^unknown replica parameter 'translaton_stiffness'; did you mean "
                                            r"'translation_stiffness'\?$"):
        ReplicaParameters.from_values({**values, "translaton_stiffness": 400.0})
    with pytest.raises(FicInputError, match=r"^offset_workspace must be in \[0.01, 2\]"):
        ReplicaParameters.from_values({**values, "offset_workspace": 5.0})
    replica = ReplicaStation(parameters)
    assert replica.authority.bounds.max_offset_speed == values["max_offset_speed"]
    assert replica.driver.base_frame == values["base_frame"] and replica.loop.parameters.controller == "fic"
    # The loop's part: its own rows only, the same values; a run-time change replaces it, the station's copy stays.
    assert set(dataclasses.asdict(replica.loop.parameters)) == set(REPLICA_LOOP_PARAMETERS)
    assert replica.configure({"control_rate": 500.0}).control_rate == 500.0 == replica.loop.parameters.control_rate
    with pytest.raises(FicInputError, match="^offset_workspace: fixed at start"):   # the input authority's
        replica.configure({"offset_workspace": 0.5, "control_rate": 250.0})
    with pytest.raises(FicInputError, match="^unknown replica parameter 'use_sim_time'"):
        replica.configure({"use_sim_time": True})
    assert replica.loop.parameters.control_rate == 500.0


def test_the_table_says_which_rows_change_at_run_time() -> None:
    """The node declares each row read-only or not by the table, and rclpy refuses a live change of a read-only row
    before the station sees it; the station changes the loop's rows only. So every row that is not the loop's
    (the driver's, the input authority's, the channel port's, the observer's) is read-only in the table, and
    the input authority's bounds among them: a live change of one is refused by the station too."""
    changeable = {name for name, row in REPLICA_PARAMETERS.items() if not row.read_only}
    assert changeable <= set(REPLICA_LOOP_PARAMETERS)
    assert all(REPLICA_PARAMETERS[name].read_only for name in AUTHORITY_PARAMETERS)
    replica = station()
    for name in AUTHORITY_PARAMETERS:
        with pytest.raises(FicInputError, match=f"^{name}: fixed at start"):
            replica.configure({name: 1.0})   # inside every one of their ranges


def run(replica: ReplicaStation, start: float, ticks: int) -> float:
    now = start
    for _ in range(ticks):
        now += PERIOD
        ok, reason = replica.admits_joint_state(now, now)
        assert ok and not reason
        replica.joint_state(now, now, Q0, QD0, round(now * 1e9))
    return now


def teleop(replica: ReplicaStation, now: float, offset, writers: int = 1) -> list[tuple[str, str]]:
    return replica.teleoperation_command(round(now * 1e9), now, mode=0, haptic_gain=0.5, workspace_scale=1.0,
                                         velocity_gain=2.0, handle_position=np.zeros(3), desired_offset=offset,
                                         writers=writers)


def test_every_guarded_stream_has_its_owner() -> None:
    assert "/ft_sensor/wrench" in ROBOT_STREAMS and "/planner/desired_pose" in SET_POINT_STREAMS
    assert stream_owner("/ft_sensor/wrench") == "the robot's"
    assert stream_owner("/planner/desired_accel") == "the planner's"
    assert stream_owner("/replica/master_port_energy") == "the channel's"


@pytest.mark.parametrize("topic", ROBOT_STREAMS + SET_POINT_STREAMS + CHANNEL_STREAMS)
def test_a_second_writer_of_a_guarded_stream_is_the_safe_hold_named_once(topic: str) -> None:
    replica = station()
    now = run(replica, 0.0, 10)
    assert replica.writers(topic, ["/robot"]) == "" and not replica.held
    reason = replica.writers(topic, ["/robot", "/outside_client"])
    assert topic in reason and "/outside_client" in reason and stream_owner(topic) in reason
    assert replica.held and replica.hold_reason == reason
    assert replica.writers(topic, ["/robot", "/outside_client"]) == ""   # said once
    # From then on nothing is taken: no joint state, no command, no set-point.
    torques = replica.loop.counts["rejected_joint_states"]
    assert replica.admits_joint_state(now + PERIOD, now + PERIOD) == (False, "")
    assert replica.loop.counts["rejected_joint_states"] == torques + 1
    assert teleop(replica, now, [0.05, 0.0, 0.0]) == [] and replica.loop.counts["teleop_commands"] == 0
    assert replica.planner_pose(0, [0.5, 0.0, 0.4], [1.0, 0.0, 0.0, 0.0], now) == []
    assert replica.loop.counts["planner_poses"] == 0
    assert replica.guard_values()["input_safe_hold"] == reason


def test_a_matched_second_writer_holds_before_discovery_names_it() -> None:
    replica = station()
    assert replica.matched("/franka/joint_states", 1, "/joint_states") == ""
    reason = replica.matched("/franka/joint_states", 2, "/joint_states")
    assert "2 publishers matched on /franka/joint_states" in reason and "the robot's" in reason and replica.held


def test_joint_state_stamps_back_in_time_or_from_the_future_hold() -> None:
    replica = station()
    now = run(replica, 0.0, 5)
    usable, reason = replica.admits_joint_state(now - 0.1, now)
    assert not usable and "went back" in reason and replica.held
    other = station()
    usable, reason = other.admits_joint_state(10.0, 0.0)
    assert not usable and "future" in reason and other.held


def test_a_second_teleop_writer_is_refused_while_it_lasts_without_a_hold() -> None:
    replica = station()
    now = run(replica, 0.0, 5)
    notices = teleop(replica, now, [0.01, 0.0, 0.0], writers=2)
    assert notices and notices[0][0] == "repeated_error" and "2 publishers" in notices[0][1]
    assert replica.loop.counts["rejected_teleop_commands"] == 1 and replica.authority.refused == 1
    assert not replica.held and replica.loop.counts["teleop_commands"] == 0
    assert teleop(replica, now, [0.0, 0.0, 0.0]) == [] and replica.loop.counts["teleop_commands"] == 1


def test_a_command_outside_the_workspace_is_clamped_and_said() -> None:
    replica = station()
    now = run(replica, 0.0, 5)
    notices = teleop(replica, now, [10.0, 0.0, 0.0])
    assert any(level == "repeated_warning" and "workspace" in text for level, text in notices), notices
    with pytest.raises(FicInputError):
        teleop(replica, now, [np.nan, 0.0, 0.0])


def test_the_wrench_is_taken_in_the_declared_frame_and_refused_to_zero_in_another() -> None:
    replica = station()
    force, torque, error = replica.wrench("panda_link0", [1.0, 2.0, 3.0], [0.1, 0.0, 0.0])
    assert error is None and force.tolist() == [1.0, 2.0, 3.0] and replica.loop.counts["wrenches"] == 1
    force, torque, error = replica.wrench("tool0", [1.0, 2.0, 3.0], [0.1, 0.0, 0.0])
    assert isinstance(error, FicInputError) and not force.any() and not torque.any()
    assert replica.loop.counts["rejected_wrenches"] == 1


def test_the_command_names_its_state_and_a_refused_state_repeats_the_last_command() -> None:
    replica = station()
    tick, error = replica.named_joint_state(0.002, 0.002, list(ARM_JOINT_NAMES), Q0.tolist(), QD0.tolist(),
                                            2_000_000)
    assert error is None and tick.command is not None and tick.state_stamp_ns == 2_000_000
    # config/replica.yaml: gravity in the command (the simulated Panda), so the command is the law's tau.
    np.testing.assert_array_equal(tick.command, tick.step.torque)
    tick2, error = replica.named_joint_state(0.004, 0.004, ["a", "b"], [0.0, 0.0], [0.0, 0.0], 4_000_000)
    assert isinstance(error, FicInputError) and tick2.state_stamp_ns == 2_000_000
    np.testing.assert_array_equal(tick2.command, tick.command)


def test_the_gravity_compensating_driver_sends_tau_minus_gravity() -> None:
    plain, franka = station(), station(gravity_compensated_by_robot=True)
    a = plain.joint_state(0.002, 0.002, Q0, QD0, 2_000_000)
    b = franka.joint_state(0.002, 0.002, Q0, QD0, 2_000_000)
    np.testing.assert_allclose(b.command, a.command - plain.loop.robot.gravity, atol=1e-9)


def test_the_loops_own_hold_is_said_once_and_the_law_resumes_after_healthy_ticks() -> None:
    replica = station(loop_resume_ticks=5.0, loop_resume_ramp=0.02)
    now = run(replica, 0.0, 20)
    now += 0.1   # a 100 ms gap between ticks: beyond loop_max_tick_gap
    tick = replica.joint_state(now, now, Q0, QD0, round(now * 1e9))
    assert tick.hold_began and tick.step.held
    now += PERIOD
    tick = replica.joint_state(now, now, Q0, QD0, round(now * 1e9))
    assert not tick.hold_began and tick.step.held
    now = run(replica, now, 10)
    tick = replica.joint_state(now + PERIOD, now + PERIOD, Q0, QD0)
    assert not tick.step.held and tick.step.command is not None and replica.loop.health.holds == 1


def ticks(replica: ReplicaStation, start: float, count: int) -> list:
    return [replica.joint_state(start + k * PERIOD, start + k * PERIOD, Q0, QD0) for k in range(1, count + 1)]


def test_feedback_goes_back_at_the_pose_rate_with_the_ports_input_energy() -> None:
    replica = station()
    assert all(tick.feedback is None for tick in ticks(replica, 0.0, 20))   # no F/T reading yet: nothing to send
    replica.wrench(replica.base_frame, [1.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    due = [tick for tick in ticks(replica, 20 * PERIOD, 20) if tick.step.poses_due]
    assert due and all(tick.feedback is not None for tick in due)
    force, energy = due[-1].feedback
    assert force.tolist() == [1.0, 0.0, 0.0] and energy == replica.channel_port.input_energy
    np.testing.assert_array_equal(replica.channel_port.force_sent, [1.0, 0.0, 0.0])
    quiet = [tick for tick in ticks(replica, 40 * PERIOD, 20) if not tick.step.poses_due]
    assert quiet and all(tick.feedback is None for tick in quiet)    # between the pose ticks nothing goes back
    replica.wrench("tool0", [1.0, 2.0, 3.0], [0.0, 0.0, 0.0])         # refused: the operator feels nothing
    sent = [tick.feedback for tick in ticks(replica, 60 * PERIOD, 20) if tick.feedback is not None]
    assert sent and sent[-1][0].tolist() == [0.0, 0.0, 0.0]


def test_the_read_outs_and_totals_say_what_the_loop_did() -> None:
    replica = station()
    assert replica.last_command is None and replica.base_frame == replica.driver.base_frame
    run(replica, 0.0, 10)
    assert replica.last_command is replica.loop.last_command is not None
    np.testing.assert_array_equal(replica.offset_in_use, np.zeros(3))   # no teleoperation command yet
    assert replica.passivity_margin == float(replica.loop.passivity.margin.min())
    totals = replica.totals()
    assert totals.holds == 0 and totals.limit_violation_ticks == replica.loop.controller.violation_ticks
    assert totals.shaped_ticks == replica.loop.controller.shaped_ticks
    assert totals.passivity_min_margin <= 0.0 and totals.passivity_violation_ticks >= 0
    np.testing.assert_array_equal(replica.tick_dynamics(), replica.loop.robot.nonlinear_effects)
