"""The paper's scenes (experiments section), added to the MuJoCo model of the Panda by name.

The robot's base frame ``panda_link0`` is the world origin, z up, so every constant here is also in the base
frame the controller and the scripted operators use.

- ``free_space``: the floor only.
- ``superimposition`` (paper E1, Fig. 5): a table in front of the robot; the autonomous circle (0.20 m diameter,
  5 s period) lies in a horizontal plane 0.25 m above the table top; two wooden blocks stand on the circle, one
  fixed to the table and one free that the robot can push away.
- ``shape_sorting`` (paper E2, Fig. 4): a shape-sorting box with three holes (cuboid, octagonal prism, six-point
  star = dodecagonal star prism), the three matching pieces on the table, and a flat end-effector plate replacing
  the gripper, to which a piece sticks through the adhesive bond (adhesive_bond.py; the paper's Velcro strap).

MuJoCo collides convex shapes only, so the box's top plate is built from convex prisms around each hole: the
part of a square cell that lies outside the hole, cut along the rays from the hole's centre through the hole's
vertices, is convex for every hole that is star-shaped about its centre (which all three are).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

SCENE_NAMES: tuple[str, ...] = ("free_space", "superimposition", "shape_sorting")

# Collision filtering (see mujoco_panda.py): the robot has contype=1, conaffinity=0 so it does not collide with
# itself; the scene has both bits so it collides with the robot and with itself.
SCENE_CONTYPE = 1
SCENE_CONAFFINITY = 1

WOOD_RGBA = (0.72, 0.53, 0.33, 1.0)
DARK_WOOD_RGBA = (0.55, 0.38, 0.22, 1.0)
TABLE_RGBA = (0.80, 0.78, 0.74, 1.0)

# --- The table (both task scenes) --------------------------------------------------------------------------------
#: Height of the table top above the robot base [m]: a low bench in front of the robot, clear of its base.
TABLE_TOP_HEIGHT = 0.10
#: Centre (x, y) of the table top and its size (x, y) [m]: from 0.25 m to 0.85 m in front of the base.
TABLE_CENTRE_XY = (0.55, 0.0)
TABLE_SIZE_XY = (0.60, 1.00)

# --- E1: superimposition -----------------------------------------------------------------------------------------
#: The paper's autonomous circle: 0.20 m diameter, 5 s period, here horizontal (in the x-y plane of the base)
#: with its centre 0.25 m above the table top, between the two obstacles. The planner and the scripted operator
#: read these (the planner's circle-centre parameter defaults to this point).
CIRCLE_CENTRE = (0.45, 0.0, TABLE_TOP_HEIGHT + 0.25)
CIRCLE_DIAMETER = 0.20
CIRCLE_PERIOD = 5.0
#: Two orthonormal axes spanning the circle's plane (x-y plane); the normal is +z.
CIRCLE_PLANE_AXES = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
CIRCLE_PLANE_NORMAL = (0.0, 0.0, 1.0)

#: Fixed obstacle: a wooden block welded to the table on the circle's +y extreme. Its top (0.38 m) is above the
#: circle's plane so the hand hits its side.
FIXED_OBSTACLE_POSITION = (CIRCLE_CENTRE[0], CIRCLE_CENTRE[1] + CIRCLE_DIAMETER / 2, TABLE_TOP_HEIGHT + 0.14)
FIXED_OBSTACLE_HALF_SIZE = (0.03, 0.03, 0.14)
#: Pushable obstacle: a free wooden box on the circle's -y extreme, light and on low friction so the robot can
#: push it out of the workspace (the paper's second obstacle). Its friction takes priority over the table's
#: (MuJoCo otherwise uses the larger of the two), so it slides at about mu*m*g = 1.2 N.
PUSHABLE_OBSTACLE_POSITION = (CIRCLE_CENTRE[0], CIRCLE_CENTRE[1] - CIRCLE_DIAMETER / 2, TABLE_TOP_HEIGHT + 0.135)
PUSHABLE_OBSTACLE_HALF_SIZE = (0.05, 0.05, 0.135)
PUSHABLE_OBSTACLE_MASS = 0.5
PUSHABLE_OBSTACLE_FRICTION = 0.25

# --- E2: shape sorting -------------------------------------------------------------------------------------------
#: The sorting box: centre (x, y) on the table, outer half sizes, and the height of its top surface.
SORTER_CENTRE_XY = (0.55, 0.0)
SORTER_HALF_SIZE_XY = (0.07, 0.16)
SORTER_TOP_HEIGHT = TABLE_TOP_HEIGHT + 0.10
SORTER_PLATE_THICKNESS = 0.012
SORTER_WALL_THICKNESS = 0.01
#: Each hole sits in a square cell of this half size in the top plate, the cells side by side along y.
SORTER_CELL_HALF_SIZE = 0.05
#: Clearance between a piece and its hole, per side [m]: a fine-manipulation fit, not a press fit.
HOLE_CLEARANCE = 0.003

PIECE_HEIGHT = 0.04
PIECE_DENSITY = 700.0  # wood [kg/m^3]


@dataclass(frozen=True)
class ShapeSortingPiece:
    """One piece and its hole. Positions are of the piece's body origin (its centre) and of the hole's centre
    on the box's top surface, in the base frame; both share the orientation (identity: edges along x and y)."""

    name: str
    shape: str  # "cuboid" | "octagonal_prism" | "star_prism"
    start_position: tuple[float, float, float]
    hole_position: tuple[float, float, float]


_PIECE_START_X = 0.38
_HOLE_YS = (-0.10, 0.0, 0.10)
SHAPE_SORTING_PIECES: tuple[ShapeSortingPiece, ...] = tuple(
    ShapeSortingPiece(
        name=f"piece_{shape}",
        shape=shape,
        start_position=(_PIECE_START_X, y, TABLE_TOP_HEIGHT + PIECE_HEIGHT / 2),
        hole_position=(SORTER_CENTRE_XY[0], y, SORTER_TOP_HEIGHT),
    )
    for shape, y in zip(("cuboid", "octagonal_prism", "star_prism"), _HOLE_YS)
)

#: Piece cross-sections (centred polygons, counter-clockwise) [m].
CUBOID_HALF_SIZE_XY = (0.025, 0.015)
OCTAGON_APOTHEM = 0.024  # across flats 0.048 m: wider than the star hole's waist, so it cannot pass there
#: Six points, twelve vertices: the paper's "star-shaped dodecagonal prism". With the inner radius at
#: outer/sqrt(3) the star is a hexagram, the union of two triangles: two convex parts for the physics, so a
#: star resting on the table costs 8 contacts, not 28.
STAR_POINTS = 6
STAR_OUTER_RADIUS = 0.032  # points beyond the octagon hole's corners, so it cannot pass there
STAR_INNER_RADIUS = STAR_OUTER_RADIUS / math.sqrt(3.0)

#: End-effector plate replacing the gripper (shape_sorting): a square plate on panda_hand whose lower face is at
#: the TCP, so "TCP on the piece's top face" means "plate on the piece". Massless: the controller's Pinocchio
#: model (the URDF with the fingers) is then still the model that moves; the fingers are hidden and do not collide.
PLATE_HALF_SIZE = (0.035, 0.035, 0.005)
PLATE_GEOM = "ee_plate"
HAND_BODY = "panda_hand"
FINGER_BODIES = ("panda_leftfinger", "panda_rightfinger")
PLATE_RGBA = (0.25, 0.25, 0.28, 1.0)
_TCP_OFFSET_IN_HAND = 0.1034  # panda_hand_tcp is 0.1034 m along the hand's z (URDF)

PIECE_RGBA = {
    "cuboid": (0.85, 0.20, 0.15, 1.0),
    "octagonal_prism": (0.20, 0.65, 0.25, 1.0),
    "star_prism": (0.20, 0.35, 0.85, 1.0),
}


@dataclass(frozen=True)
class SceneLayout:
    """What the simulation needs to know about the scene it built."""

    name: str
    movable_bodies: tuple[str, ...]  # free bodies (their poses are published on /sim/object_poses)
    bond_piece_bodies: tuple[str, ...]  # bodies the adhesive plate can bond with (empty without a plate)
    plate_geom: str | None


# --- polygons ----------------------------------------------------------------------------------------------------
def rectangle_polygon(half_x: float, half_y: float) -> np.ndarray:
    return np.array([[half_x, -half_y], [half_x, half_y], [-half_x, half_y], [-half_x, -half_y]])


def regular_polygon(sides: int, apothem: float, phase: float) -> np.ndarray:
    radius = apothem / math.cos(math.pi / sides)
    angles = phase + 2.0 * math.pi * np.arange(sides) / sides
    return radius * np.column_stack([np.cos(angles), np.sin(angles)])


def star_polygon(points: int, outer_radius: float, inner_radius: float, phase: float) -> np.ndarray:
    angles = phase + math.pi * np.arange(2 * points) / points
    radii = np.where(np.arange(2 * points) % 2 == 0, outer_radius, inner_radius)
    return np.column_stack([radii * np.cos(angles), radii * np.sin(angles)])


# Octagon with flats facing x and y; star with a point along +x.
_OCTAGON_PHASE = math.pi / 8
_STAR_PHASE = 0.0


def piece_polygon(shape: str, grow: float = 0.0) -> np.ndarray:
    """Cross-section of a piece (grow=0) or of its hole (grow=HOLE_CLEARANCE), centred, counter-clockwise."""
    if shape == "cuboid":
        return rectangle_polygon(CUBOID_HALF_SIZE_XY[0] + grow, CUBOID_HALF_SIZE_XY[1] + grow)
    if shape == "octagonal_prism":
        return regular_polygon(8, OCTAGON_APOTHEM + grow, _OCTAGON_PHASE)
    if shape == "star_prism":
        # Offsetting an equilateral triangle's edges by `grow` moves its corners out by 2*grow: the hole is the
        # hexagram of the two offset triangles, every edge exactly `grow` from the piece's.
        outer = STAR_OUTER_RADIUS + 2.0 * grow
        return star_polygon(STAR_POINTS, outer, outer / math.sqrt(3.0), _STAR_PHASE)
    raise ValueError(f"unknown piece shape {shape!r}")


def _clip(polygon: list[np.ndarray], point: np.ndarray, direction: np.ndarray) -> list[np.ndarray]:
    """Sutherland-Hodgman: keep the part of a convex polygon left of the line through point along direction."""

    def side(p: np.ndarray) -> float:
        return float(direction[0] * (p[1] - point[1]) - direction[1] * (p[0] - point[0]))

    kept: list[np.ndarray] = []
    for i, current in enumerate(polygon):
        previous = polygon[i - 1]
        s_cur, s_prev = side(current), side(previous)
        if s_cur >= 0.0:
            if s_prev < 0.0:
                kept.append(previous + (current - previous) * s_prev / (s_prev - s_cur))
            kept.append(current)
        elif s_prev >= 0.0:
            kept.append(previous + (current - previous) * s_prev / (s_prev - s_cur))
    return kept


def cell_minus_hole(hole: np.ndarray, cell_half_size: float) -> list[np.ndarray]:
    """Convex pieces covering the square cell minus a hole star-shaped about the origin (CCW vertices)."""
    square = [np.array(p, dtype=float) for p in rectangle_polygon(cell_half_size, cell_half_size)]
    origin = np.zeros(2)
    pieces = []
    for k in range(len(hole)):
        a, b = hole[k], hole[(k + 1) % len(hole)]
        region = _clip(square, origin, a)  # left of the ray through a
        region = _clip(region, origin, -b) if region else region  # right of the ray through b
        region = _clip(region, a, a - b) if region else region  # outside the edge a->b
        if len(region) >= 3:
            poly = np.array(region)
            area = 0.5 * abs(np.dot(poly[:, 0], np.roll(poly[:, 1], -1)) - np.dot(poly[:, 1], np.roll(poly[:, 0], -1)))
            if area > 1e-8:
                pieces.append(poly)
    return pieces


def convex_parts(shape: str) -> list[np.ndarray]:
    """The piece's cross-section as convex polygons (the hexagram star as its two overlapping triangles)."""
    polygon = piece_polygon(shape)
    if shape != "star_prism":
        return [polygon]
    points = polygon[0::2]  # the six outer points; alternate ones make the two triangles
    return [points[0::2], points[1::2]]


def _add_prism(spec: mujoco.MjSpec, body: mujoco.MjsBody, name: str, polygon: np.ndarray, z_centre: float,
               half_height: float, rgba, **geom_attributes) -> None:
    """A convex prism as a mesh geom (MuJoCo collides the convex hull of a mesh, which is the prism itself)."""
    vertices = []
    for z in (z_centre - half_height, z_centre + half_height):
        for x, y in polygon:
            vertices += [float(x), float(y), z]
    spec.add_mesh(name=name, uservert=vertices)
    body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name, rgba=rgba,
                  contype=SCENE_CONTYPE, conaffinity=SCENE_CONAFFINITY, **geom_attributes)


def _add_static_box(body: mujoco.MjsBody, name: str, centre, half_size, rgba, **attributes) -> None:
    body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, pos=list(centre), size=list(half_size), rgba=rgba,
                  contype=SCENE_CONTYPE, conaffinity=SCENE_CONAFFINITY, **attributes)


# --- scene builders ----------------------------------------------------------------------------------------------
def _add_floor_and_light(spec: mujoco.MjSpec) -> None:
    spec.add_texture(name="floor_grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                     rgb1=[0.32, 0.34, 0.38], rgb2=[0.26, 0.28, 0.31], width=256, height=256)
    spec.add_material(name="floor", textures=["", "floor_grid"], texrepeat=[8, 8], reflectance=0.0)
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[3.0, 3.0, 0.05], material="floor",
                            contype=SCENE_CONTYPE, conaffinity=SCENE_CONAFFINITY)
    spec.worldbody.add_light(name="key_light", pos=[0.6, -0.8, 2.0], dir=[-0.25, 0.35, -1.0], castshadow=False,
                             diffuse=[0.7, 0.7, 0.7])
    spec.worldbody.add_light(name="fill_light", pos=[-0.8, 0.8, 2.0], dir=[0.4, -0.4, -1.0], castshadow=False,
                             diffuse=[0.35, 0.35, 0.35])


def _add_table(spec: mujoco.MjSpec) -> None:
    half = (TABLE_SIZE_XY[0] / 2, TABLE_SIZE_XY[1] / 2, TABLE_TOP_HEIGHT / 2)
    table = spec.worldbody.add_body(name="table", pos=[TABLE_CENTRE_XY[0], TABLE_CENTRE_XY[1], TABLE_TOP_HEIGHT / 2])
    _add_static_box(table, "table_top", (0, 0, 0), half, TABLE_RGBA)


def _add_superimposition(spec: mujoco.MjSpec) -> SceneLayout:
    _add_table(spec)
    fixed = spec.worldbody.add_body(name="fixed_obstacle", pos=list(FIXED_OBSTACLE_POSITION))
    _add_static_box(fixed, "fixed_obstacle", (0, 0, 0), FIXED_OBSTACLE_HALF_SIZE, DARK_WOOD_RGBA)
    pushable = spec.worldbody.add_body(name="pushable_obstacle", pos=list(PUSHABLE_OBSTACLE_POSITION))
    pushable.add_freejoint(name="pushable_obstacle")
    pushable.add_geom(name="pushable_obstacle", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(PUSHABLE_OBSTACLE_HALF_SIZE),
                      mass=PUSHABLE_OBSTACLE_MASS, rgba=WOOD_RGBA, friction=[PUSHABLE_OBSTACLE_FRICTION, 0.005, 0.0001],
                      priority=1, contype=SCENE_CONTYPE, conaffinity=SCENE_CONAFFINITY)
    return SceneLayout("superimposition", ("pushable_obstacle",), (), None)


def _add_sorter_box(spec: mujoco.MjSpec) -> None:
    cx, cy = SORTER_CENTRE_XY
    hx, hy = SORTER_HALF_SIZE_XY
    box = spec.worldbody.add_body(name="sorter", pos=[cx, cy, 0.0])
    plate_z = SORTER_TOP_HEIGHT - SORTER_PLATE_THICKNESS / 2
    half_t = SORTER_PLATE_THICKNESS / 2
    wall_half_h = (SORTER_TOP_HEIGHT - SORTER_PLATE_THICKNESS - TABLE_TOP_HEIGHT) / 2
    wall_z = TABLE_TOP_HEIGHT + wall_half_h
    w = SORTER_WALL_THICKNESS / 2
    # Four walls under the top plate; the table is the floor, so a released piece falls inside.
    _add_static_box(box, "sorter_wall_front", (-hx + w, 0, wall_z), (w, hy, wall_half_h), DARK_WOOD_RGBA)
    _add_static_box(box, "sorter_wall_back", (hx - w, 0, wall_z), (w, hy, wall_half_h), DARK_WOOD_RGBA)
    _add_static_box(box, "sorter_wall_right", (0, -hy + w, wall_z), (hx - 2 * w, w, wall_half_h), DARK_WOOD_RGBA)
    _add_static_box(box, "sorter_wall_left", (0, hy - w, wall_z), (hx - 2 * w, w, wall_half_h), DARK_WOOD_RGBA)
    # Top plate: border strips around the three cells, and each cell minus its hole as convex prisms.
    c = SORTER_CELL_HALF_SIZE
    cells_half_y = 3 * c
    strip_x = (hx - c) / 2
    _add_static_box(box, "sorter_top_front", (-(c + strip_x), 0, plate_z), (strip_x, hy, half_t), WOOD_RGBA)
    _add_static_box(box, "sorter_top_back", (c + strip_x, 0, plate_z), (strip_x, hy, half_t), WOOD_RGBA)
    strip_y = (hy - cells_half_y) / 2
    if strip_y > 0:
        _add_static_box(box, "sorter_top_right", (0, -(cells_half_y + strip_y), plate_z), (c, strip_y, half_t),
                        WOOD_RGBA)
        _add_static_box(box, "sorter_top_left", (0, cells_half_y + strip_y, plate_z), (c, strip_y, half_t), WOOD_RGBA)
    for piece in SHAPE_SORTING_PIECES:
        offset = np.array([piece.hole_position[0] - cx, piece.hole_position[1] - cy])
        for k, region in enumerate(cell_minus_hole(piece_polygon(piece.shape, HOLE_CLEARANCE), c)):
            _add_prism(spec, box, f"sorter_top_{piece.shape}_{k}", region + offset, plate_z, half_t, WOOD_RGBA)


def _add_plate_on_hand(spec: mujoco.MjSpec) -> None:
    hand = spec.body(HAND_BODY)
    z = _TCP_OFFSET_IN_HAND - PLATE_HALF_SIZE[2]
    # density 0 and the hand's explicit URDF inertia keep the arm's dynamics identical to Pinocchio's model.
    hand.add_geom(name=PLATE_GEOM, type=mujoco.mjtGeom.mjGEOM_BOX, pos=[0, 0, z], size=list(PLATE_HALF_SIZE),
                  density=0.0, rgba=PLATE_RGBA, contype=1, conaffinity=0, friction=[1.0, 0.005, 0.0001])
    for finger in FINGER_BODIES:  # the plate replaces the gripper: fingers neither collide nor show
        for geom in spec.body(finger).geoms:
            geom.contype = 0
            geom.conaffinity = 0
            geom.rgba = [0, 0, 0, 0]


def _add_shape_sorting(spec: mujoco.MjSpec) -> SceneLayout:
    _add_table(spec)
    _add_sorter_box(spec)
    _add_plate_on_hand(spec)
    bodies = []
    for piece in SHAPE_SORTING_PIECES:
        body = spec.worldbody.add_body(name=piece.name, pos=list(piece.start_position))
        body.add_freejoint(name=piece.name)
        for k, part in enumerate(convex_parts(piece.shape)):
            _add_prism(spec, body, f"{piece.name}_{k}", part, 0.0, PIECE_HEIGHT / 2, PIECE_RGBA[piece.shape],
                       density=PIECE_DENSITY)
        bodies.append(piece.name)
    return SceneLayout("shape_sorting", tuple(bodies), tuple(bodies), PLATE_GEOM)


def add_scene(spec: mujoco.MjSpec, name: str) -> SceneLayout:
    """Add the floor, lights and the named scene's objects to a spec that already holds the Panda."""
    if name not in SCENE_NAMES:
        raise ValueError(f"scene must be one of {SCENE_NAMES}, got {name!r}")
    _add_floor_and_light(spec)
    if name == "superimposition":
        return _add_superimposition(spec)
    if name == "shape_sorting":
        return _add_shape_sorting(spec)
    return SceneLayout("free_space", (), (), None)
