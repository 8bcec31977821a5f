"""Rigid-body terms of the Panda for the replica law (paper Eq. 7), from Pinocchio.

One ``update(q, qd)`` a control tick computes everything the replica needs in one pass, on the same URDF that
the simulator loads (``panda_description``): the TCP pose, its Jacobian in the base-aligned frame, g(q),
C(q, qd) qd, M(q) and M(q)^-1. The accessors then only read the cached results, so the control law, the
null-space posture and the postural optimisation all see the same state.
"""
from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_array
from .panda_description import JOINT_DAMPING, load_pinocchio_model

_LOCAL_WORLD_ALIGNED = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_FLOAT64 = np.dtype(np.float64)


def checked_array(name: str, value: ArrayLike, shape: tuple[int, ...]) -> NDArray[np.float64]:
    """``finite_array`` with a fast path for the 1 kHz tick: one sum detects any NaN/Inf (they propagate);
    only a suspicious input takes the full check, which raises FicInputError naming ``name``."""
    array = np.asarray(value, dtype=np.float64) if not isinstance(value, np.ndarray) or value.dtype != np.float64 \
        else value
    if array.shape == shape and math.isfinite(array.sum()):
        return array
    return finite_array(name, value, shape)  # raises, unless a huge finite input overflowed the sum


def _state_vector(name: str, value: ArrayLike, size: int) -> tuple[NDArray[np.float64], list[float]]:
    """A fresh float64 copy of a joint vector and its values as floats, checked with one sum (NaN/Inf propagate
    into it); a suspicious input takes ``finite_array``, which raises FicInputError naming ``name``."""
    if type(value) is np.ndarray and value.dtype is _FLOAT64 and value.shape == (size,):
        array = value.copy()  # the common case, at half the cost of np.array(value, dtype=np.float64)
    else:
        try:
            array = np.array(value, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise FicInputError(f"{name} must be numeric, got {value!r}") from exc
        if array.shape != (size,):
            raise FicInputError(f"{name} must have shape {(size,)}, got {array.shape}")
    values = array.tolist()
    if not math.isfinite(sum(values)):
        finite_array(name, array, (size,))  # raises, unless a huge finite input overflowed the sum
    return array, values


class RobotState:
    """The arm's state and its rigid-body terms at one (q, qd): what ``RobotModel.update`` computed.

    One object per RobotModel, refilled by each ``update`` (a new object a tick would cost about a microsecond of
    the replica's budget): read its fields right after the update, and copy what must outlive the next one. The
    arrays q, qd, the TCP pose, Jacobian and twist are fresh each update; ``mass_matrix_inverse`` and
    ``nonlinear_effects`` are views into Pinocchio's Data, which the next update overwrites.
    """

    __slots__ = ("q", "qd", "q_values", "qd_values", "tcp_position", "tcp_rotation", "tcp_jacobian", "tcp_twist",
                 "mass_matrix_inverse", "nonlinear_effects")

    q: NDArray[np.float64]                     # joint positions [rad] (7,)
    qd: NDArray[np.float64]                    # joint velocities [rad/s] (7,)
    q_values: list[float]                      # q as Python floats, for per-joint arithmetic on the tick
    qd_values: list[float]                     # qd as Python floats
    tcp_position: NDArray[np.float64]          # x_R [m] (3,), base frame
    tcp_rotation: NDArray[np.float64]          # R, base <- TCP (3, 3)
    tcp_jacobian: NDArray[np.float64]          # J (6, 7), LOCAL_WORLD_ALIGNED: [v; w] = J qd in the base frame
    tcp_twist: NDArray[np.float64]             # [v; w] = J qd (6,)
    mass_matrix_inverse: NDArray[np.float64]   # M(q)^-1 (7, 7), symmetric
    nonlinear_effects: NDArray[np.float64]     # C(q, qd) qd + G(q) [N m] (7,)


class RobotModel:
    """Pinocchio model of the 7-DoF Panda arm (fingers locked, simulator's armature mirrored).

    Cartesian quantities are in the base frame ``panda_link0``; the Jacobian is LOCAL_WORLD_ALIGNED (the TCP's
    linear velocity and the angular velocity, both expressed in the base frame), axis order x, y, z, rx, ry, rz.
    """

    def __init__(self, model: pin.Model | None = None, tcp_frame_id: int | None = None) -> None:
        if model is None:
            model, _, default_frame = load_pinocchio_model()
            tcp_frame_id = default_frame if tcp_frame_id is None else tcp_frame_id
        elif tcp_frame_id is None:
            raise FicInputError("tcp_frame_id is required when a model is given")
        self.model = model
        self.data = model.createData()
        self.tcp_frame_id = int(tcp_frame_id)
        self.dof = int(model.nv)
        if model.nq != model.nv:
            raise FicInputError(f"model must have nq == nv (revolute joints only), got nq={model.nq}, nv={model.nv}")
        self.lower_position_limit: NDArray[np.float64] = np.array(model.lowerPositionLimit, dtype=float)
        self.upper_position_limit: NDArray[np.float64] = np.array(model.upperPositionLimit, dtype=float)
        self.urdf_velocity_limit: NDArray[np.float64] = np.array(model.velocityLimit, dtype=float)
        self.urdf_effort_limit: NDArray[np.float64] = np.array(model.effortLimit, dtype=float)
        #: Viscous joint damping of the real (simulated) arm; used to predict the next joint velocity.
        self.joint_damping: NDArray[np.float64] = np.full(self.dof, JOINT_DAMPING)
        for array in (self.lower_position_limit, self.upper_position_limit, self.urdf_velocity_limit,
                      self.urdf_effort_limit, self.joint_damping):
            array.flags.writeable = False
        self._updated = False
        #: The terms of the last ``update`` (refilled by each; see RobotState).
        self.state = RobotState()
        self._zero_acceleration = np.zeros(self.dof)  # qdd = 0 of Jdot qd, made once (read-only to Pinocchio)
        self._zero_acceleration.flags.writeable = False
        # A reference into data.oMf (never resized), fetched once: indexing the vector costs a microsecond a tick.
        self._tcp_placement = self.data.oMf[self.tcp_frame_id]

    def update(self, q: ArrayLike, qd: ArrayLike) -> RobotState:
        """Compute kinematics and dynamics at (q, qd) and return them (``state``, refilled: see RobotState).
        Raises FicInputError on NaN/Inf or a wrong shape.

        The arrays the accessors return are valid until the next ``update`` (copy them to keep them); ``q``,
        ``qd``, the TCP pose, Jacobian and twist are fresh arrays each update, never overwritten.
        """
        dof = self.dof
        shape = (dof,)
        if type(q) is np.ndarray and type(qd) is np.ndarray and q.dtype is _FLOAT64 and qd.dtype is _FLOAT64 \
                and q.shape == shape and qd.shape == shape:
            # The common tick: fresh copies, and one sum for both (NaN/Inf propagate into it); a suspicious pair
            # takes _state_vector, which raises FicInputError naming the culprit.
            q, qd = q.copy(), qd.copy()
            q_values, qd_values = q.tolist(), qd.tolist()
            if not math.isfinite(sum(q_values) + sum(qd_values)):
                q, q_values = _state_vector("q", q, dof)
                qd, qd_values = _state_vector("qd", qd, dof)
        else:
            q, q_values = _state_vector("q", q, dof)
            qd, qd_values = _state_vector("qd", qd, dof)
        model, data, frame = self.model, self.data, self.tcp_frame_id
        # One pass for the TCP: computeFrameJacobian runs the forward kinematics of the frame's support, sets
        # data.oMf[frame] and returns a new array (cheaper than computeJointJacobians + updateFramePlacement +
        # getFrameJacobian, the same numbers: test_robot_model checks J against finite differences).
        jacobian = pin.computeFrameJacobian(model, data, q, frame, _LOCAL_WORLD_ALIGNED)
        pose = self._tcp_placement.homogeneous  # a new 4x4 array: no copy needed to keep the pose
        # nonLinearEffects and computeMinverse return views of distinct members of `data` (nle, Minv), which only
        # the next update overwrites. Pinocchio 4 fills both triangles of Minv (checked in test_robot_model).
        state = self.state
        state.nonlinear_effects = pin.nonLinearEffects(model, data, q, qd)  # C(q, qd) qd + g(q)
        state.mass_matrix_inverse = pin.computeMinverse(model, data, q)
        state.tcp_jacobian = jacobian
        state.tcp_position = pose[:3, 3]
        state.tcp_rotation = pose[:3, :3]
        state.q = q
        state.qd = qd
        state.q_values = q_values  # the same numbers as Python floats, for per-joint arithmetic (the replica)
        state.qd_values = qd_values
        state.tcp_twist = jacobian.dot(qd)  # ndarray.dot: half the call overhead of @ on these small arrays
        # Computed on first use only: the replica's tick does not need them.
        self._gravity = None
        self._mass = None
        self._kinetic_energy = None
        self._bias_acceleration = None
        self._updated = True
        return state

    def _require_update(self) -> None:
        if not self._updated:
            raise RuntimeError("RobotModel.update(q, qd) must be called before reading the model")

    @property
    def q(self) -> NDArray[np.float64]:
        self._require_update()
        return self.state.q

    @property
    def qd(self) -> NDArray[np.float64]:
        self._require_update()
        return self.state.qd

    @property
    def tcp_position(self) -> NDArray[np.float64]:
        """TCP position in the base frame [m] (3,)."""
        self._require_update()
        return self.state.tcp_position

    @property
    def tcp_rotation(self) -> NDArray[np.float64]:
        """TCP orientation, base <- TCP rotation matrix (3, 3)."""
        self._require_update()
        return self.state.tcp_rotation

    @property
    def tcp_jacobian(self) -> NDArray[np.float64]:
        """6x7 TCP Jacobian, LOCAL_WORLD_ALIGNED: [v; w] = J qd, both in the base frame."""
        self._require_update()
        return self.state.tcp_jacobian

    @property
    def tcp_twist(self) -> NDArray[np.float64]:
        """TCP twist [v; w] in the base frame (6,)."""
        self._require_update()
        return self.state.tcp_twist

    @property
    def tcp_speed(self) -> float:
        """Linear speed of the TCP [m/s]."""
        self._require_update()
        velocity = self.state.tcp_twist[:3]
        return math.sqrt(velocity @ velocity)

    @property
    def tcp_bias_acceleration(self) -> NDArray[np.float64]:
        """Jdot(q, qd) qd: the TCP's classical acceleration [a; alpha] at zero joint acceleration, base frame (6,).

        The TCP acceleration is J qdd + Jdot qd; the replica's inertial feedforward subtracts this term.
        """
        self._require_update()
        if self._bias_acceleration is None:
            model, data = self.model, self.data
            # Overwrites data's placements, velocities and accelerations only (not nle or Minv, which the
            # accessors return views of); the pose and Jacobian were kept as arrays of their own.
            pin.forwardKinematics(model, data, self.state.q, self.state.qd, self._zero_acceleration)
            self._bias_acceleration = pin.getFrameClassicalAcceleration(model, data, self.tcp_frame_id,
                                                                        _LOCAL_WORLD_ALIGNED).vector.copy()
        return self._bias_acceleration

    @property
    def gravity(self) -> NDArray[np.float64]:
        """G(q) [N m] (7,)."""
        self._require_update()
        if self._gravity is None:
            self._gravity = pin.computeGeneralizedGravity(self.model, self.data, self.state.q).copy()
        return self._gravity

    @property
    def coriolis(self) -> NDArray[np.float64]:
        """C(q, qd) qd, Coriolis and centrifugal torques [N m] (7,)."""
        self._require_update()
        return self.state.nonlinear_effects - self.gravity

    @property
    def nonlinear_effects(self) -> NDArray[np.float64]:
        """C(q, qd) qd + G(q) [N m] (7,)."""
        self._require_update()
        return self.state.nonlinear_effects

    @property
    def mass_matrix(self) -> NDArray[np.float64]:
        """M(q) incl. the joint armature [kg m^2] (7, 7), symmetric (Pinocchio 4 fills both triangles)."""
        self._require_update()
        if self._mass is None:
            self._mass = pin.crba(self.model, self.data, self.state.q).copy()
        return self._mass

    @property
    def mass_matrix_inverse(self) -> NDArray[np.float64]:
        """M(q)^-1 (7, 7), symmetric."""
        self._require_update()
        return self.state.mass_matrix_inverse

    @property
    def kinetic_energy(self) -> float:
        """0.5 qd^T M(q) qd [J]."""
        self._require_update()
        if self._kinetic_energy is None:
            self._kinetic_energy = float(pin.computeKineticEnergy(self.model, self.data, self.state.q, self.state.qd))
        return self._kinetic_energy

    def joint_position_margin(self, q: ArrayLike | None = None) -> NDArray[np.float64]:
        """Distance of each joint to its nearest URDF limit [rad]; negative when beyond a limit."""
        q = self.q if q is None else finite_array("q", q, (self.dof,))
        return np.minimum(q - self.lower_position_limit, self.upper_position_limit - q)
