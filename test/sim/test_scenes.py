"""The scenes build, rest still under the hold torque, and the shape sorter's holes are the pieces' shapes."""
import mujoco
import numpy as np
import pytest

from sim_bridge.robot import scenes
from sim_bridge.robot.mujoco_panda import PandaSimulation
from sim_bridge.robot.scenes import (
    HOLE_CLEARANCE,
    SHAPE_SORTING_PIECES,
    SORTER_CELL_HALF_SIZE,
    cell_minus_hole,
    convex_parts,
    piece_polygon,
)


@pytest.mark.parametrize("scene", scenes.SCENE_NAMES)
def test_each_scene_builds_and_rests_still_for_2_s_under_the_hold_torque(scene):
    sim = PandaSimulation(scene, seed=0)
    start_q = sim.joint_positions
    start_objects = sim.object_poses()
    for _ in range(2000):
        sim.step(sim.hold_torque())
    assert sim.time == pytest.approx(2.0)
    assert np.abs(sim.joint_positions - start_q).max() < 1e-3
    assert np.all(np.isfinite(sim.data.qvel)) and np.abs(sim.data.qvel).max() < 1e-2
    for name, (position, _) in sim.object_poses().items():  # objects settle where they were put
        assert np.linalg.norm(position - start_objects[name][0]) < 2e-3, name
    assert not sim.ft_wrench().any()  # the robot touches nothing at its nominal pose


def test_unknown_scene_is_rejected():
    with pytest.raises(ValueError, match="scene must be one of"):
        PandaSimulation("kitchen", seed=0)


def _inside(polygon: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Even-odd rule point-in-polygon, vectorised over points."""
    inside = np.zeros(len(points), dtype=bool)
    for a, b in zip(polygon, np.roll(polygon, -1, axis=0)):
        crosses = (a[1] > points[:, 1]) != (b[1] > points[:, 1])
        x_cross = a[0] + (points[:, 1] - a[1]) * (b[0] - a[0]) / np.where(b[1] == a[1], 1e-300, b[1] - a[1])
        inside ^= crosses & (points[:, 0] < x_cross)
    return inside


@pytest.mark.parametrize("piece", SHAPE_SORTING_PIECES, ids=lambda p: p.shape)
def test_plate_pieces_cover_the_cell_exactly_outside_the_hole_and_the_piece_fits(piece):
    hole = piece_polygon(piece.shape, HOLE_CLEARANCE)
    regions = cell_minus_hole(hole, SORTER_CELL_HALF_SIZE)
    # An irrational offset keeps grid points off the regions' shared edges (rays through vertices, the axes).
    grid = np.linspace(-SORTER_CELL_HALF_SIZE, SORTER_CELL_HALF_SIZE, 160, endpoint=False) + 1e-4 * np.sqrt(2.0)
    points = np.array([(x, y) for x in grid for y in grid])
    in_hole = _inside(hole, points)
    covered = np.zeros(len(points), dtype=bool)
    for region in regions:
        covered |= _inside(region, points)
    assert not np.any(covered & in_hole)  # nothing of the plate inside the hole
    assert np.all(covered | in_hole)  # and no gap in the plate
    # The piece (its convex parts) lies inside the hole, the clearance away from the hole's edges.
    piece_points = points[np.any([_inside(part, points) for part in convex_parts(piece.shape)], axis=0)]
    assert len(piece_points) > 100 and np.all(_inside(hole, piece_points))
    shrunk_hole = piece_polygon(piece.shape, HOLE_CLEARANCE - 0.002)
    assert np.all(_inside(shrunk_hole, piece_points))


def test_the_star_has_twelve_vertices_and_the_octagon_eight():
    assert len(piece_polygon("star_prism")) == 12 and len(piece_polygon("octagonal_prism")) == 8


@pytest.mark.parametrize("index", range(3), ids=[p.shape for p in SHAPE_SORTING_PIECES])
def test_each_piece_drops_through_its_own_hole_and_not_through_the_others(index):
    """Physics check of the holes: a piece released above its hole falls into the box; above another hole it
    stays on the top plate."""
    for target in range(3):
        sim = PandaSimulation("shape_sorting", seed=0)
        piece = SHAPE_SORTING_PIECES[index]
        hole = np.array(SHAPE_SORTING_PIECES[target].hole_position)
        joint = sim.model.joint(piece.name)
        sim.data.qpos[joint.qposadr[0]:joint.qposadr[0] + 3] = hole + np.array([0.0, 0.0, 0.03])
        mujoco.mj_forward(sim.model, sim.data)
        for _ in range(400):
            sim.step(sim.hold_torque())
        height = sim.data.xpos[sim.model.body(piece.name).id][2]
        if target == index:
            assert height < scenes.SORTER_TOP_HEIGHT - scenes.PIECE_HEIGHT, (piece.shape, target)
        else:
            assert height > scenes.SORTER_TOP_HEIGHT, (piece.shape, target)
