"""The MuJoCo Panda: the same URDF Pinocchio loads (fic_core.panda_description), effort-controlled at 1 kHz.

Model recipe: MuJoCo 4.0 neither resolves ``package://`` nor reads .dae, and would give the fingers
free prismatic joints that the controller's 7-DoF model locks; so the URDF text is rewritten (absolute mesh
paths, finger joints fixed, ``<mimic>`` dropped, a ``<mujoco><compiler>`` element that discards the .dae visuals
and keeps the massless ``panda_hand_tcp`` body), then edited as an ``MjSpec``: 1 ms implicitfast steps, the joint
damping and armature that fic_core's Pinocchio model mirrors, seven torque motors limited to the Franka's
87/12 N m, no self-collision (robot geoms contype=1, conaffinity=0; scene geoms both 1), and a ``tcp`` site.

Rendering uses the collision meshes, coloured (30-45 ms a frame in software, versus about 110 ms for the converted
visual meshes, and nothing to convert, cache or keep in step with the URDF); see render.py.

Stepping is split around ``mj_step2``/``mj_step1`` so that after ``step`` every kinematic quantity (TCP pose,
gravity and Coriolis terms for ``hold_torque``) belongs to the new state, while the contact and bond forces read
for the wrist wrench are those that acted during the step just taken (a sensor averaging over the interval).
"""
from __future__ import annotations

import math
import re

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from fic_core.errors import FicInputError
from fic_core.panda_description import (
    ARM_JOINT_NAMES,
    FINGER_JOINT_NAMES,
    HAND_FRAME,
    JOINT_ARMATURE,
    JOINT_DAMPING,
    NOMINAL_CONFIGURATION,
    TCP_FRAME,
    panda_description,
)

from .adhesive_bond import AdhesiveBond, BondParameters, BondState, add_bond_welds
from .scenes import FINGER_BODIES, SceneLayout, add_scene
from .wrist_wrench import WristWrench

TIMESTEP = 0.001  # [s] the Franka's torque interface runs at 1 kHz
#: Franka Emika Panda joint torque limits [N m] (datasheet; also the URDF's effort limits).
TORQUE_LIMITS = np.array([87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0])
_LOWER_TORQUE = -TORQUE_LIMITS   # made once: the clamp runs at every 1 kHz step
TCP_SITE = "tcp"
#: Damping added by ``hold_torque`` on top of the joints' own [N m s/rad]: brakes a moving arm within about a
#: second without exciting the wrist (whose link inertias are small).
HOLD_DAMPING = np.array([10.0, 10.0, 10.0, 10.0, 2.0, 2.0, 2.0])

ROBOT_RGBA = {
    "panda_link0": (0.92, 0.92, 0.92, 1.0),
    "panda_link1": (0.95, 0.95, 0.95, 1.0),
    "panda_link2": (0.95, 0.95, 0.95, 1.0),
    "panda_link3": (0.95, 0.95, 0.95, 1.0),
    "panda_link4": (0.95, 0.95, 0.95, 1.0),
    "panda_link5": (0.95, 0.95, 0.95, 1.0),
    "panda_link6": (0.95, 0.95, 0.95, 1.0),
    "panda_link7": (0.30, 0.30, 0.32, 1.0),
    "panda_hand": (0.93, 0.93, 0.93, 1.0),
    "panda_leftfinger": (0.20, 0.20, 0.22, 1.0),
    "panda_rightfinger": (0.20, 0.20, 0.22, 1.0),
}


def _as_slice(indices: NDArray[np.int64]) -> slice | NDArray[np.int64]:
    """``indices`` as a slice when they are consecutive and increasing (the same elements, read faster)."""
    first = int(indices[0])
    if indices.tolist() == list(range(first, first + len(indices))):
        return slice(first, first + len(indices))
    return indices


def panda_urdf_for_mujoco() -> str:
    """The Panda URDF text, rewritten so that MuJoCo compiles it (see the module docstring)."""
    description = panda_description()
    text = description.urdf_path.read_text()
    text = text.replace("package://example-robot-data/robots/panda_description/", f"{description.package_dir}/")
    text = re.sub(r"<mimic[^>]*/>", "", text)
    for finger in FINGER_JOINT_NAMES:
        text, count = re.subn(rf'(<joint name="{finger}" type=")prismatic"', r'\1fixed"', text)
        if count != 1:
            raise RuntimeError(f"the Panda URDF no longer declares {finger} as prismatic; update mujoco_panda.py")
    compiler = '<mujoco><compiler discardvisual="true" fusestatic="false" balanceinertia="false"/></mujoco>'
    text, count = re.subn(r"(<robot [^>]*>)", rf"\1{compiler}", text, count=1)
    if count != 1:
        raise RuntimeError("no <robot> element in the Panda URDF")
    return text


def build_panda_spec(gravity_compensation: bool = False) -> mujoco.MjSpec:
    """The robot alone, with the simulation settings, actuators, collision bits and TCP site.

    ``gravity_compensation``: the arm compensates its own weight at every physics step, as a Franka under torque
    control does (docs/HARDWARE.md): every robot body gets MuJoCo's ``gravcomp = 1``, a passive force
    (qfrc_gravcomp) outside the actuators, so the torque command then means tau - G(q), and bodies that are not
    the robot (a piece held by the adhesive bond) are not compensated, like a load the arm was not told about.
    """
    spec = mujoco.MjSpec.from_string(panda_urdf_for_mujoco())
    if gravity_compensation:
        for body in spec.bodies:
            if body.name != "world":
                body.gravcomp = 1.0
    spec.option.timestep = TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.gravity = [0.0, 0.0, -9.81]
    for name in ARM_JOINT_NAMES:
        joint = spec.joint(name)
        joint.damping = [JOINT_DAMPING, 0.0, 0.0]  # MuJoCo 4.0: damping is a 3-vector (linear term first)
        joint.armature = JOINT_ARMATURE
        joint.frictionloss = 0.0
    for geom in spec.geoms:
        geom.contype = 1
        geom.conaffinity = 0
    for body_name, rgba in ROBOT_RGBA.items():
        for geom in spec.body(body_name).geoms:
            geom.rgba = list(rgba)
    spec.body(TCP_FRAME).add_site(name=TCP_SITE, size=[0.005, 0.005, 0.005], rgba=[1, 0.5, 0, 0])
    for name, limit in zip(ARM_JOINT_NAMES, TORQUE_LIMITS):
        actuator = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.set_to_motor()
        actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        actuator.ctrlrange = [-limit, limit]
    return spec


def build_model(scene: str, gravity_compensation: bool = False) -> tuple[mujoco.MjModel, SceneLayout]:
    """Compile the Panda with the named scene (scenes.SCENE_NAMES); see build_panda_spec for the gravity."""
    spec = build_panda_spec(gravity_compensation)
    layout = add_scene(spec, scene)
    if layout.bond_piece_bodies:
        add_bond_welds(spec, HAND_FRAME, layout.bond_piece_bodies)
    return spec.compile(), layout


class PandaSimulation:
    """One simulated Panda in a scene: torques in, joint state, TCP pose and wrist wrench out. No ROS in here.

    ``seed`` draws the adhesive bond's break thresholds (the only random element); the scene's layout is fixed so
    that scripted operators know where things are.
    """

    def __init__(self, scene: str, seed: int, initial_configuration: ArrayLike = NOMINAL_CONFIGURATION,
                 bond_parameters: BondParameters = BondParameters(), gravity_compensation: bool = False) -> None:
        self._model, self.layout = build_model(scene, gravity_compensation)
        #: The arm compensates its own gravity (a Franka's semantics): commands are tau - G(q).
        self.gravity_compensation = gravity_compensation
        self._data = mujoco.MjData(self._model)
        self._initial_configuration = self._check_vector("initial_configuration", initial_configuration)
        self._arm_qpos = np.array([self._model.jnt_qposadr[self._model.joint(n).id] for n in ARM_JOINT_NAMES])
        self._arm_dof = np.array([self._model.jnt_dofadr[self._model.joint(n).id] for n in ARM_JOINT_NAMES])
        # The arm's joints come first in every scene, in order: a slice reads them at a fraction of the cost of
        # indexing with the arrays above (read at every 1 kHz step); any other layout keeps the index arrays.
        self._arm_qpos_read = _as_slice(self._arm_qpos)
        self._arm_dof_read = _as_slice(self._arm_dof)
        self._tcp_site = self._model.site(TCP_SITE).id
        self._hand_body = self._model.body(HAND_FRAME).id
        self._tcp_body = self._model.body(TCP_FRAME).id  # the tcp site sits at its origin, unrotated
        # (name, body id) of the scene's movable bodies, looked up once: the video asks for their poses at 30 Hz.
        self._movable_bodies = [(name, self._model.body(name).id) for name in self.layout.movable_bodies]
        self._wrist = WristWrench(self._model, (HAND_FRAME, TCP_FRAME) + FINGER_BODIES)
        self._bond = (AdhesiveBond(self._model, self.layout.plate_geom, HAND_FRAME, self.layout.bond_piece_bodies,
                                   np.random.default_rng(seed), bond_parameters)
                      if self.layout.plate_geom else None)
        self._applied_torque = np.zeros(7)
        self._wrench = np.zeros(6)
        self._steps = 0
        self.reset(seed)

    # --- inputs ------------------------------------------------------------------------------------------------
    @staticmethod
    def _check_vector(name: str, value: ArrayLike) -> NDArray[np.float64]:
        try:
            array = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise FicInputError(f"{name} must be 7 numbers, got {value!r}") from exc
        if array.shape != (7,):
            raise FicInputError(f"{name} must have 7 elements (one per arm joint), got shape {array.shape}")
        # The sum is finite exactly when every element is (barring overflow, re-checked element-wise): the cheap
        # test first, because this runs on every 1 kHz command (Python's sum of the floats: numpy's reduction costs
        # more on 7 elements).
        if not math.isfinite(sum(array.tolist())) and not np.isfinite(array).all():
            raise FicInputError(f"{name} must be finite, got {array}")
        return array

    def reset(self, seed: int) -> None:
        """Back to the initial configuration at rest, objects at their start poses, bond thresholds reseeded."""
        mujoco.mj_resetData(self._model, self._data)
        self._data.qpos[self._arm_qpos] = self._initial_configuration
        if self._bond is not None:
            self._bond.reset(self._data, np.random.default_rng(seed))
        self._applied_torque = np.zeros(7)
        self._wrench = np.zeros(6)
        self._steps = 0
        mujoco.mj_forward(self._model, self._data)

    def step(self, torque: ArrayLike) -> None:
        """Apply joint torques [N m] (clamped to the Franka limits) for one 1 ms step.

        Raises FicInputError (a ValueError) for NaN/Inf or a length other than 7; the physics is then untouched.
        """
        command = np.minimum(np.maximum(self._check_vector("torque", torque), _LOWER_TORQUE), TORQUE_LIMITS)
        model, data = self._model, self._data
        data.ctrl[:] = command
        self._applied_torque = command
        mujoco.mj_step2(model, data)  # forces of the current state, then integrate
        # The contacts and forces are still those of the state before integration: use that state's TCP too.
        tcp = data.site_xpos[self._tcp_site].copy()
        self._wrench = self._wrist.contact_wrench(model, data, tcp)
        if self._bond is not None:
            self._wrench += self._bond.update(model, data, tcp)
        mujoco.mj_step1(model, data)  # kinematics, bias forces and contacts of the new state
        self._steps += 1

    # --- outputs -----------------------------------------------------------------------------------------------
    @property
    def model(self) -> mujoco.MjModel:
        return self._model

    @property
    def data(self) -> mujoco.MjData:
        return self._data

    @property
    def time(self) -> float:
        return float(self._data.time)

    @property
    def steps(self) -> int:
        return self._steps

    @property
    def joint_positions(self) -> NDArray[np.float64]:
        return self._data.qpos[self._arm_qpos_read].copy()

    @property
    def joint_velocities(self) -> NDArray[np.float64]:
        return self._data.qvel[self._arm_dof_read].copy()

    @property
    def applied_torque(self) -> NDArray[np.float64]:
        """The torque actually applied in the last step (after clamping)."""
        return self._applied_torque.copy()

    @property
    def tcp_pose(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(position [m], rotation matrix 3x3) of panda_hand_tcp in the base frame (= world: base at origin)."""
        return (self._data.site_xpos[self._tcp_site].copy(), self._data.site_xmat[self._tcp_site].reshape(3, 3).copy())

    @property
    def tcp_quaternion(self) -> NDArray[np.float64]:
        """Orientation of panda_hand_tcp as a unit quaternion (w, x, y, z), base frame."""
        return self._data.xquat[self._tcp_body].copy()

    def ft_wrench(self) -> NDArray[np.float64]:
        """Force [N] and torque [N m] the environment applies to the end-effector, about the TCP, base frame.

        Order fx, fy, fz, tx, ty, tz. Contacts on hand, fingers and plate plus the adhesive bond; no weight or
        inertia of the hand (see wrist_wrench.py). Refers to the forces acting during the last step.
        """
        return self._wrench.copy()

    @property
    def bond_state(self) -> BondState | None:
        return None if self._bond is None else self._bond.state

    def drain_bond_events(self) -> list[str]:
        return [] if self._bond is None else self._bond.drain_events()

    def hold_torque(self, damping: ArrayLike = HOLD_DAMPING) -> NDArray[np.float64]:
        """Gravity and Coriolis compensation plus damping, -D qd: what the watchdog applies to hold the arm (without
        the gravity when the arm compensates it itself)."""
        bias = self._data.qfrc_bias[self._arm_dof]
        if self.gravity_compensation:
            bias = bias - self._data.qfrc_gravcomp[self._arm_dof]
        return bias - np.asarray(damping, dtype=np.float64) * self.joint_velocities

    def object_poses(self) -> dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]:
        """Pose (position, quaternion w x y z) of every movable scene body."""
        xpos, xquat = self._data.xpos, self._data.xquat
        return {name: (xpos[body].copy(), xquat[body].copy()) for name, body in self._movable_bodies}
