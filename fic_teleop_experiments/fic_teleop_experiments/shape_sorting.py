"""E2 outcome from a bag: which pieces ended inside the sorting box (paper Fig. 4).

A piece SUCCEEDED when its last recorded position (/sim/object_poses, the robot sim's ground truth) is inside the
box: within the inner walls in x and y and below the underside of the top plate (so through its hole and
released, not resting on the lid or still stuck to the plate above it). The box is sim_bridge.robot.scenes' constants.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from fic_teleop_tools.verdict.bag_series import RunSeries
from sim_bridge.robot.scenes import (
    SHAPE_SORTING_PIECES,
    SORTER_CENTRE_XY,
    SORTER_HALF_SIZE_XY,
    SORTER_PLATE_THICKNESS,
    SORTER_TOP_HEIGHT,
    SORTER_WALL_THICKNESS,
    TABLE_TOP_HEIGHT,
)

#: Order of /sim/object_poses in the shape_sorting scene (scenes.SceneLayout.movable_bodies).
PIECE_NAMES = tuple(piece.name for piece in SHAPE_SORTING_PIECES)


def inside_box(position: np.ndarray) -> bool:
    """Whether a piece's centre lies inside the box: inner walls in x, y; under the lid; above the table."""
    x, y, z = (float(v) for v in position)
    inner_x = SORTER_HALF_SIZE_XY[0] - SORTER_WALL_THICKNESS
    inner_y = SORTER_HALF_SIZE_XY[1] - SORTER_WALL_THICKNESS
    return (abs(x - SORTER_CENTRE_XY[0]) < inner_x and abs(y - SORTER_CENTRE_XY[1]) < inner_y
            and TABLE_TOP_HEIGHT < z < SORTER_TOP_HEIGHT - SORTER_PLATE_THICKNESS)


@dataclass
class PieceOutcome:
    name: str
    inside: bool
    final_position: list[float]
    moved: float          # [m] from its start position
    lifted: float         # [m] highest rise of its centre above the start

    def as_dict(self) -> dict:
        return asdict(self)


def piece_outcomes(series: RunSeries) -> list[PieceOutcome]:
    """One outcome per piece (empty when the bag has no object poses)."""
    positions = series.object_positions
    if positions.size == 0 or positions.shape[1] != len(PIECE_NAMES):
        return []
    outcomes = []
    for index, piece in enumerate(SHAPE_SORTING_PIECES):
        track = positions[:, index, :]
        start = np.asarray(piece.start_position)
        outcomes.append(PieceOutcome(
            name=piece.name, inside=inside_box(track[-1]), final_position=[float(v) for v in track[-1]],
            moved=float(np.linalg.norm(track[-1] - start)), lifted=float(np.max(track[:, 2]) - start[2])))
    return outcomes
