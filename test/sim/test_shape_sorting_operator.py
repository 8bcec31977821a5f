"""The shape-sorting operator (sim_bridge/device/shape_sorting_operator.py) on a kinematic replica: its commands go
through the master's mode integrator and a delayed channel, its video comes back through another, and it must bring
the seen TCP over the first piece by move-and-wait before it presses."""
from __future__ import annotations

import numpy as np
import pytest

from fic_core.errors import FicInputError
from fic_core.teleoperation import TeleoperationCommandIntegrator
from sim_bridge.channel.channel import Channel, ChannelConfig
from sim_bridge.device.shape_sorting_operator import (
    _RAMP_SHAPE,
    ShapeSortingOperator,
    ShapeSortingParameters,
    SortingFrame,
    velocity_step,
)
from sim_bridge.device.virtual_operator import BUTTON_TOGGLE_MODE
from sim_bridge.robot.scenes import PIECE_HEIGHT, SHAPE_SORTING_PIECES

REFERENCE = np.array([0.45, 0.0, 0.35])      # the planner's fixed point in E2
PIECES = np.array([piece.start_position for piece in SHAPE_SORTING_PIECES])
TICK, FRAME_EVERY = 0.004, 8                 # the 250 Hz device, a 31 Hz camera


def excursion_area(excursion: float, hold: float, ramp: float, deadband: float) -> float:
    """The area beyond the dead-band of a ramp out, a hold and a ramp back (what velocity mode integrates)."""
    ramps = 2.0 * ramp * float(np.mean(np.maximum(0.0, excursion * _RAMP_SHAPE - deadband)))
    return ramps + hold * (excursion - deadband)


@pytest.mark.parametrize("travel", [0.004, 0.02, 0.17])
def test_velocity_step_moves_the_offset_by_the_travel(travel):
    excursion, hold = velocity_step(travel, 0.05, 0.005, 2.0, 0.5)
    assert excursion <= 0.05 + 1e-12 and hold >= 0.0
    assert excursion_area(excursion, hold, 0.5, 0.005) * 2.0 == pytest.approx(travel, rel=1e-3)


def test_a_frame_is_used_only_a_perception_delay_after_it_arrives():
    operator = ShapeSortingOperator(ShapeSortingParameters(perception_delay=0.3))
    operator.see(1.0, SortingFrame(0.8, REFERENCE, PIECES))
    operator.target(1.29)
    assert operator.seen is None
    operator.target(1.3)
    assert operator.seen is not None and operator.seen.stamp == 0.8


def test_contact_is_what_is_felt_beyond_the_learnt_handle_spring():
    operator = ShapeSortingOperator(ShapeSortingParameters(learnt_stiffness=100.0, learnt_max_force=4.0))
    handle = np.array([0.0, 0.0, -0.02])
    operator.feel(np.array([0.0, 0.0, 2.0]), handle)             # the handle's own spring only: no contact
    assert np.allclose(operator.felt_contact, 0.0)
    operator.feel(np.array([0.0, 0.0, 3.5]), handle)             # 1.5 N more pushing the handle up: a contact
    assert operator.felt_contact[2] == pytest.approx(1.5)
    operator.feel(np.array([0.0, 0.0, 4.0]), np.array([0.0, 0.0, -0.08]))   # the spring's bound, not 8 N
    assert np.allclose(operator.felt_contact, 0.0)


def test_bad_input_is_refused_with_one_clear_error():
    operator = ShapeSortingOperator()
    with pytest.raises(FicInputError, match="pieces"):
        operator.see(0.1, SortingFrame(0.0, REFERENCE, PIECES[:2]))
    with pytest.raises(FicInputError):
        operator.feel(np.array([np.nan, 0.0, 0.0]), np.zeros(3))
    with pytest.raises(FicInputError, match="max_corrections"):
        ShapeSortingParameters(max_corrections=0)


def reach_first_piece(delay: float, duration: float = 30.0):
    """Drive a kinematic replica (x_R = reference + x_d', x_d' from the master's integrator on the hand target, the
    command and the video each ``delay`` late) until the operator starts its grasp. Returns the operator, the
    replica's TCP at that moment and the time."""
    parameters = ShapeSortingParameters(assumed_one_way_delay=delay)
    operator = ShapeSortingOperator(parameters)
    integrator = TeleoperationCommandIntegrator(1.0, parameters.velocity_gain,
                                                velocity_deadband=parameters.velocity_deadband)
    forward, video = Channel(ChannelConfig(delay=delay, seed=1)), Channel(ChannelConfig(delay=delay, seed=2))
    offset = np.zeros(3)
    for k in range(int(round(duration / TICK))):
        now = k * TICK
        tcp = REFERENCE + offset
        if k % FRAME_EVERY == 0:
            video.push(SortingFrame(now, tcp.copy(), PIECES), now, now)
        for delivery in video.pop_due(now):
            operator.see(now, delivery.payload)
        operator.feel(np.zeros(3), np.zeros(3))
        hand = operator.target(now)
        for event in operator.poll_events(now):
            assert event.button == BUTTON_TOGGLE_MODE
            integrator.toggle_mode()
        forward.push(integrator.update(hand, TICK), now, now)
        for delivery in forward.pop_due(now):
            offset = delivery.payload
        if any(label.endswith(":grasp") for label, _, _ in operator.moves_started):
            return operator, tcp, now
    return operator, REFERENCE + offset, duration


@pytest.mark.parametrize("delay", [0.0, 0.2, 0.5])
def test_move_and_wait_brings_the_plate_over_the_first_piece_through_the_delay(delay):
    operator, tcp, when = reach_first_piece(delay)
    hover = PIECES[0] + np.array([0.0, 0.0, PIECE_HEIGHT / 2 + operator.parameters.hover])
    assert when < 30.0, "the operator never reached its grasp"
    assert np.linalg.norm(tcp - hover) <= operator.parameters.travel_tolerance + 0.003
    # The travel was in velocity mode and every step was judged on what was seen after it: a longer delay waits
    # longer between steps.
    steps = [start for label, start, _ in operator.moves_started if label.startswith("cuboid:reach_")]
    gaps = np.diff(steps)
    assert gaps[gaps > 0].min() >= 2.0 * delay + operator.parameters.perception_delay


@pytest.mark.slow
def test_on_the_simulated_robot_the_operator_grasps_the_first_piece_through_200_ms():
    """The in-process runner (the MuJoCo Panda with the adhesive bond, the FIC as E2 runs it): within 20 s the
    operator reaches the cuboid, presses until it feels the contact and lifts it on the plate; the other pieces
    have not moved. Measured (seed 1, 2026-12-05): press felt at 15.5 s with 4.8 N, lifted at 16.5 s."""
    from fic_teleop_experiments.in_process import RunConfig, run

    result = run(RunConfig(scene="shape_sorting", trajectory="fixed", duration=20.0, delay=0.2, seed=1,
                           operator="shape_sorting", hand="reactive", replica_overrides={"paper_law": True}))
    phases = [label for label, _, _ in result.operator_moves]
    assert phases.index("cuboid:press_felt") < phases.index("cuboid:lift")
    felt = next(value for label, _, value in result.operator_moves if label == "cuboid:press_felt")
    assert felt >= 1.0
    cuboid, others = result.objects["piece_cuboid"][0], [result.objects[p.name][0] for p in SHAPE_SORTING_PIECES[1:]]
    assert cuboid[2] > SHAPE_SORTING_PIECES[0].start_position[2] + 0.02       # lifted on the plate
    for position, piece in zip(others, SHAPE_SORTING_PIECES[1:]):
        assert np.linalg.norm(position - np.asarray(piece.start_position)) < 0.005
    assert result.limit_violations == 0
