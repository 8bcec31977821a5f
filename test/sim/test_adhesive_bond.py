"""The plate-piece bond (the paper's Velcro): forms on a firm press, carries the piece, breaks above its threshold."""
import mujoco
import numpy as np
import pytest
from cartesian_helper import cartesian_torque

from sim_bridge.robot.adhesive_bond import BondParameters
from sim_bridge.robot.mujoco_panda import PandaSimulation
from sim_bridge.robot.scenes import PIECE_HEIGHT, SHAPE_SORTING_PIECES


def _pick(sim: PandaSimulation, piece_index: int) -> tuple[np.ndarray, np.ndarray]:
    _, down = sim.tcp_pose
    piece = SHAPE_SORTING_PIECES[piece_index]
    top = np.array(piece.start_position) + np.array([0.0, 0.0, PIECE_HEIGHT / 2])
    for height, steps in ((0.10, 800), (0.01, 700)):  # above the piece, then just above it
        for _ in range(steps):
            sim.step(cartesian_torque(sim, top + np.array([0.0, 0.0, height]), down))
    assert sim.bond_state.bonded_piece is None
    for _ in range(1000):  # down onto it, pressing with 6 N (formation needs 3 N)
        sim.step(cartesian_torque(sim, top, down, force=np.array([0.0, 0.0, -6.0]), stiffness=np.array([400, 400,
                                                                                                        0.0])))
        if sim.bond_state.bonded_piece is not None:
            break
    return top, down


def test_bond_forms_on_press_carries_the_piece_and_breaks_above_its_threshold():
    sim = PandaSimulation("shape_sorting", seed=3)
    top, down = _pick(sim, 0)
    state = sim.bond_state
    assert state.bonded_piece == SHAPE_SORTING_PIECES[0].name and state.bonds_formed == 1
    assert 5.0 <= state.break_threshold <= 20.0
    body = sim.model.body(SHAPE_SORTING_PIECES[0].name).id
    for _ in range(1000):  # lift it 10 cm
        sim.step(cartesian_torque(sim, top + np.array([0.0, 0.0, 0.10]), down))
    assert sim.data.xpos[body][2] > SHAPE_SORTING_PIECES[0].start_position[2] + 0.08
    weight = sim.model.body_subtreemass[body] * 9.81
    # The F/T sensor feels the hanging piece's weight through the bond (and nothing else). The bond itself
    # carries at least the weight: more when the plate also presses on the piece (weld pull + contact push).
    assert sim.ft_wrench()[2] == pytest.approx(-weight, rel=0.02)
    assert sim.bond_state.bond_force > 0.98 * weight
    threshold = sim.bond_state.break_threshold
    peak = 0.0
    for k in range(2500):  # pull the piece down with a slowly growing external force until the bond gives
        sim.data.xfrc_applied[body, 2] = -0.02 * k
        sim.step(cartesian_torque(sim, top + np.array([0.0, 0.0, 0.10]), down))
        if sim.bond_state.breaks:
            break
        peak = max(peak, sim.bond_state.bond_force)
    assert sim.bond_state.breaks == 1 and sim.bond_state.bonded_piece is None
    assert peak <= threshold < sim.bond_state.last_break_force < threshold + 0.2
    sim.data.xfrc_applied[body] = 0.0
    for _ in range(500):  # the piece falls free: nothing on the sensor
        sim.step(cartesian_torque(sim, top + np.array([0.0, 0.0, 0.10]), down))
    assert sim.data.xpos[body][2] < top[2]
    assert not sim.ft_wrench().any()
    events = sim.drain_bond_events()
    assert len(events) == 2 and "formed" in events[0] and "broke" in events[1]


def test_break_thresholds_are_seeded_and_vary_between_bonds():
    parameters = BondParameters()
    thresholds = []
    for seed in (1, 1, 2):
        sim = PandaSimulation("shape_sorting", seed=seed)
        _pick(sim, 1)
        assert sim.bond_state.bonded_piece == SHAPE_SORTING_PIECES[1].name
        thresholds.append(sim.bond_state.break_threshold)
    assert thresholds[0] == thresholds[1] != thresholds[2]
    assert all(parameters.break_force_min <= t <= parameters.break_force_max for t in thresholds)


def test_a_light_touch_does_not_bond():
    sim = PandaSimulation("shape_sorting", seed=0)
    _, down = sim.tcp_pose
    piece = SHAPE_SORTING_PIECES[2]
    top = np.array(piece.start_position) + np.array([0.0, 0.0, PIECE_HEIGHT / 2])
    for height, steps in ((0.10, 1200), (0.02, 800)):  # settle 2 cm above it
        for _ in range(steps):
            sim.step(cartesian_torque(sim, top + np.array([0.0, 0.0, height]), down))
    assert sim.tcp_pose[0][2] > top[2] + 0.005  # above the piece, not touching
    assert not sim.ft_wrench().any()
    touched = False
    for _ in range(1000):  # down onto it with 1 N (below the 3 N formation force), and rest there
        sim.step(cartesian_torque(sim, top, down, force=np.array([0.0, 0.0, -1.0]), stiffness=np.array([400, 400, 0.0]),
                                  damping=20.0))
        touched |= sim.ft_wrench()[2] > 0.5
    assert touched and sim.bond_state.bonds_formed == 0
    assert mujoco.mj_name2id(sim.model, mujoco.mjtObj.mjOBJ_EQUALITY, f"bond_{piece.name}") >= 0
