"""The replica's torque law (paper Eq. 7) followed by the postural optimisation (SPEC 1.5).

    tau_d = C(q, qd) qd + G(q) + J(q)^T FIC(x~_R) + tau_posture ,   x~_R = x_d - x_R ,  x_d = x_d' + x_d''
    tau   = postural_optimisation(tau_d)   (inside the torque, torque-rate, joint-velocity, joint-position and
                                            TCP-speed limits; see postural_optimisation.py)

FIC(.) is a 6-D wrench: translation on the position error, rotation (beyond the paper) on the rotation-vector
error log(R_d R^T), both in the base frame, so J is the LOCAL_WORLD_ALIGNED TCP Jacobian. The caller composes
x_d (the node adds the teleoperated offset x_d' to the planner's x_d''); this module is pure numpy/Pinocchio.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_array, finite_scalar
from .limits import VIOLATION_TOLERANCE, LimitFlag, PandaLimits, violation_flags
from .postural_optimisation import PosturalOptimisation
from .posture import NullSpacePosture
from .robot_model import RobotModel, checked_array

_ROTATION_TOLERANCE = 1e-6
_IDENTITY3 = np.eye(3)


class TaskController(Protocol):
    """What the replica needs of PoseAttractor (the FIC) and LinearImpedance (the baseline)."""

    controller_name: str

    def wrench(self, position_error: NDArray[np.float64], rotation_error: NDArray[np.float64],
               twist_error: NDArray[np.float64]) -> NDArray[np.float64]: ...

    @property
    def phase(self) -> NDArray: ...

    @property
    def latched_max_error(self) -> NDArray[np.float64]: ...

    @property
    def last_force(self) -> NDArray[np.float64]: ...

    @property
    def stored_energy(self) -> NDArray[np.float64]: ...

    def reset(self) -> None: ...


@dataclass(slots=True)
class ReplicaCommand:
    """One tick of the replica: the torque to send and everything a status message or a report needs.

    The ratios of LimitStatus are properties computed on access from the stored state, so that a tick whose
    report nobody reads does not pay for them.
    """

    torque: NDArray[np.float64]              # the command [N m] (7,), inside the limits
    unshaped_torque: NDArray[np.float64]     # tau_d of Eq. 7 before the postural optimisation (7,)
    posture_torque: NDArray[np.float64]      # tau_posture (7,), in the task's dynamically consistent null space
    wrench: NDArray[np.float64]              # FIC(x~_R) [N, N m] (6,), base frame (= the controller's force)
    tracking_error: NDArray[np.float64]      # x_d - x_R [m] (3,)
    rotation_error: NDArray[np.float64]      # log(R_d R^T) [rad] (3,), base frame
    desired_position: NDArray[np.float64]    # x_d [m] (3,)
    desired_rotation: NDArray[np.float64]    # R_d (3, 3)
    tcp_position: NDArray[np.float64]        # x_R [m] (3,)
    tcp_rotation: NDArray[np.float64]        # R (3, 3)
    limit_shaping: LimitFlag                 # limits that changed the command this tick
    limit_violations: LimitFlag              # limits the command or the measured state broke this tick
    torque_change: float                     # |tau - tau_d| [N m]
    tcp_speed: float                         # measured TCP speed [m/s]
    kinetic_energy: float                    # 0.5 qd^T M qd [J]
    controller_name: str                     # "fic" or "linear"
    phase: NDArray                           # per-axis FIC phase (6,)
    latched_max_error: NDArray[np.float64]   # (6,)
    stored_energy: NDArray[np.float64]       # (6,) [J]
    solved_qp: bool                          # the optimisation had to solve its QP this tick
    relaxed: bool                            # prediction constraints infeasible, softened
    guard_clipped: bool                      # the last-guard clip acted
    q: NDArray[np.float64]                   # measured joint positions [rad] (7,)
    qd: NDArray[np.float64]                  # measured joint velocities [rad/s] (7,)
    previous_torque: NDArray[np.float64] | None  # the command before this one (None for the first)
    control_period: float                    # [s]
    limits: PandaLimits

    @property
    def controller_force(self) -> NDArray[np.float64]:
        return self.wrench

    @property
    def total_energy(self) -> float:
        """Energy stored in the controller's springs plus the arm's kinetic energy [J]."""
        return float(self.stored_energy.sum()) + self.kinetic_energy

    @property
    def torque_ratio(self) -> NDArray[np.float64]:
        """|tau_i| / torque limit_i of the command (7,)."""
        return np.abs(self.torque) / self.limits.torque_array

    @property
    def torque_rate_ratio(self) -> NDArray[np.float64]:
        """|tau_i - tau_prev_i| / (torque-rate limit * control period) (7,); zeros for the first command."""
        if self.previous_torque is None:
            return np.zeros_like(self.torque)
        return np.abs(self.torque - self.previous_torque) / (self.limits.torque_rate * self.control_period)

    @property
    def joint_velocity_ratio(self) -> NDArray[np.float64]:
        """|qd_i| / velocity limit_i, measured (7,)."""
        return np.abs(self.qd) / self.limits.joint_velocity_array

    @property
    def joint_position_margin(self) -> NDArray[np.float64]:
        """Distance of each joint to its nearest URDF limit [rad] (7,); negative beyond it."""
        return np.minimum(self.q - self.limits.lower_array, self.limits.upper_array - self.q)


def rotation_from_quaternion(quaternion: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix of a quaternion given in ROS order (x, y, z, w); normalised, zero norm rejected."""
    quaternion = finite_array("desired_rotation", quaternion, (4,))
    norm = float(np.linalg.norm(quaternion))
    if norm < 1e-9:
        raise FicInputError(f"desired_rotation quaternion must have a non-zero norm, got {quaternion}")
    x, y, z, w = quaternion / norm
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _determinant(matrix: NDArray[np.float64]) -> float:
    (a, b, c), (d, e, f), (g, h, i) = matrix.tolist()  # 3x3 by hand: numpy.linalg.det's overhead is ~10 us
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def _desired_rotation(value: ArrayLike) -> NDArray[np.float64]:
    array = np.asarray(value, dtype=float)
    if array.shape == (4,):
        return rotation_from_quaternion(array)
    rotation = checked_array("desired_rotation", array, (3, 3))
    if np.abs(rotation.T @ rotation - _IDENTITY3).max() > _ROTATION_TOLERANCE or _determinant(rotation) <= 0.0:
        raise FicInputError(f"desired_rotation must be a rotation matrix (orthonormal, det +1), got {rotation}")
    return rotation


class ReplicaController:
    """Paper Eq. 7 with a null-space posture, then the postural optimisation, for one control tick at a time.

    ``control_period`` is the time between two ``command`` calls: it sets the torque-rate box (rate * period)
    and the prediction step. The first command after construction or ``reset()`` has no torque-rate bound
    (there is no previous command to rate against).
    """

    def __init__(self, robot: RobotModel, controller: TaskController, limits: PandaLimits | None = None,
                 posture: NullSpacePosture | None = None, control_period: float = 0.001,
                 optimisation: PosturalOptimisation | None = None) -> None:
        self.robot = robot
        self.controller = controller
        self.limits = PandaLimits.from_robot(robot) if limits is None else limits
        self.posture = NullSpacePosture(robot.lower_position_limit, robot.upper_position_limit) \
            if posture is None else posture
        self.control_period = finite_scalar("control_period", control_period, minimum=0.0, minimum_inclusive=False)
        self.optimisation = PosturalOptimisation(self.limits, self.control_period) \
            if optimisation is None else optimisation
        if abs(self.optimisation.control_period - self.control_period) > 1e-12:
            raise FicInputError("the optimisation's control_period must equal the replica's control_period")
        self._previous_torque: NDArray[np.float64] | None = None
        self._held_position: NDArray[np.float64] | None = None
        self._held_rotation: NDArray[np.float64] | None = None
        self.ticks = 0              # cumulative counters (LimitStatus ticks, shaped_ticks, violation_ticks)
        self.shaped_ticks = 0
        self.violation_ticks = 0
        rate_step = np.full(robot.dof, self.limits.torque_rate * self.control_period)
        self._bounds = np.concatenate((self.limits.torque_array, rate_step, self.limits.joint_velocity_array))
        self._first_bounds = np.concatenate((self.limits.torque_array, self.limits.joint_velocity_array))

    @property
    def previous_torque(self) -> NDArray[np.float64] | None:
        """The last command (None before the first)."""
        return None if self._previous_torque is None else self._previous_torque.copy()

    def reset(self, previous_torque: ArrayLike | None = None) -> None:
        """Forget the controller state and the last desired pose; optionally state the torque now applied."""
        self.controller.reset()
        self._previous_torque = None if previous_torque is None else \
            finite_array("previous_torque", previous_torque, (self.robot.dof,)).copy()
        self._held_position = None
        self._held_rotation = None

    def command(self, q: ArrayLike, qd: ArrayLike, desired_position: ArrayLike, desired_rotation: ArrayLike,
                desired_twist: ArrayLike | None = None) -> ReplicaCommand:
        """The torque for state (q, qd) toward the desired TCP pose (rotation: 3x3 matrix or quaternion x,y,z,w).

        ``desired_twist`` (6,) is the desired TCP twist [v; w] in the base frame (zero if omitted); the twist
        error handed to the controller is desired minus measured. Raises FicInputError on NaN/Inf or bad shapes.
        """
        desired_position = checked_array("desired_position", desired_position, (3,)).copy()
        desired_rotation = _desired_rotation(desired_rotation)
        desired_twist = None if desired_twist is None else checked_array("desired_twist", desired_twist, (6,))
        robot = self.robot
        robot.update(q, qd)  # validates q and qd
        q, qd = robot.q, robot.qd
        self._held_position = desired_position
        self._held_rotation = desired_rotation

        # Eq. 7: tau_d = C qd + G + J^T FIC(x~_R) + tau_posture.
        position = robot.tcp_position
        rotation = robot.tcp_rotation
        jacobian = robot.tcp_jacobian
        position_error = desired_position - position
        rotation_error = pin.log3(desired_rotation @ rotation.T)
        twist_error = -robot.tcp_twist if desired_twist is None else desired_twist - robot.tcp_twist
        controller = self.controller
        wrench = np.asarray(controller.wrench(position_error, rotation_error, twist_error), dtype=float)
        if wrench.shape != (6,) or not math.isfinite(wrench.sum()):
            raise FicInputError(f"the controller returned a non-finite or mis-shaped wrench: {wrench}")
        limits = self.limits
        minv = robot.mass_matrix_inverse
        position_margin = np.minimum(q - limits.lower_array, limits.upper_array - q)
        posture = self.posture
        posture_torque = posture.project(posture.joint_torque(q, qd, position_margin), jacobian, minv)
        nonlinear = robot.nonlinear_effects
        desired_torque = nonlinear + jacobian.T @ wrench + posture_torque

        # Postural optimisation: M qdd = tau - (C qd + g) - D qd in the prediction (the arm's joint damping).
        previous = self._previous_torque
        shaped = self.optimisation.shape(desired_torque, previous, q, qd, nonlinear + robot.joint_damping * qd,
                                         minv, jacobian[:3], position_margin)
        torque = shaped.torque if shaped.solved_qp else desired_torque.copy()
        tcp_speed = robot.tcp_speed
        if shaped.fast_path and tcp_speed <= limits.tcp_speed:
            violations = LimitFlag.NONE  # the fast path checked the torque, its rate, |qd| and the joint ranges
        else:
            violations = self._violations(previous, torque, qd, position_margin, tcp_speed)
        self._previous_torque = torque
        self.ticks += 1
        if shaped.flags:
            self.shaped_ticks += 1
        if violations:
            self.violation_ticks += 1

        return ReplicaCommand(
            torque=torque,
            unshaped_torque=desired_torque,
            posture_torque=posture_torque,
            wrench=wrench,
            tracking_error=position_error,
            rotation_error=rotation_error,
            desired_position=desired_position,
            desired_rotation=desired_rotation,
            tcp_position=position,
            tcp_rotation=rotation,
            limit_shaping=shaped.flags,
            limit_violations=violations,
            torque_change=shaped.torque_change,
            tcp_speed=tcp_speed,
            kinetic_energy=robot.kinetic_energy,
            controller_name=controller.controller_name,
            phase=np.asarray(controller.phase),
            latched_max_error=np.asarray(controller.latched_max_error, dtype=float),
            stored_energy=np.asarray(controller.stored_energy, dtype=float),
            solved_qp=shaped.solved_qp,
            relaxed=shaped.relaxed,
            guard_clipped=shaped.guard_clipped,
            q=q,
            qd=qd,
            previous_torque=previous,
            control_period=self.control_period,
            limits=limits,
        )

    def _violations(self, previous: NDArray[np.float64] | None, torque: NDArray[np.float64],
                    qd: NDArray[np.float64], position_margin: NDArray[np.float64], tcp_speed: float) -> LimitFlag:
        """SPEC 2.2's violation flags, with one fused test for the common all-clear tick."""
        limits = self.limits
        if previous is None:
            excess = (np.abs(np.concatenate((torque, qd))) - self._first_bounds).max()
        else:
            excess = (np.abs(np.concatenate((torque, torque - previous, qd))) - self._bounds).max()
        if excess <= VIOLATION_TOLERANCE and position_margin.min() >= -VIOLATION_TOLERANCE \
                and tcp_speed <= limits.tcp_speed + VIOLATION_TOLERANCE:
            return LimitFlag.NONE
        return violation_flags(previous, torque, self.robot.q, qd, tcp_speed, self.control_period, limits)

    def hold(self, q: ArrayLike, qd: ArrayLike) -> ReplicaCommand:
        """A safe hold: keep the last desired pose (or, before any, the current TCP pose), zero desired twist.

        The same law and the same limits as ``command``; only the target stops moving.
        """
        if self._held_position is None or self._held_rotation is None:
            self.robot.update(q, qd)
            self._held_position = self.robot.tcp_position.copy()
            self._held_rotation = self.robot.tcp_rotation.copy()
        return self.command(q, qd, self._held_position, self._held_rotation)
