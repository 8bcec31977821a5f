"""The replica's torque law (paper Eq. 7) followed by the postural optimisation (docs/CONTROL_LAWS.md).

    tau_d = C(q, qd) qd + G(q) + J(q)^T (FIC(x~_R) + Lambda a_d) + tau_posture ,   x~_R = x_d - x_R ,
                                                                                   x_d = x_d' + x_d''
    tau   = postural_optimisation(tau_d)   (inside the torque, torque-rate, joint-velocity, joint-position and
                                            TCP-speed limits; see postural_optimisation.py)

FIC(.) is a 6-D wrench: translation on the position error, rotation (beyond the paper) on the rotation-vector
error log(R_d R^T), both in the base frame, so J is the LOCAL_WORLD_ALIGNED TCP Jacobian. The caller composes
x_d (the node adds the teleoperated offset x_d' to the planner's x_d''); this module is pure numpy/Pinocchio.

Inertial feedforward (beyond paper Eq. 7, optional): ``command(..., desired_acceleration=a_d)`` adds
J^T Lambda (a_d - Jdot qd), with Lambda = (J M^-1 J^T + mu I)^-1 the TCP's operational-space inertia and a_d
the desired TCP acceleration [a; alpha] in the base frame (a 3-vector a means alpha = 0: the orientation is
held). Why: the FIC has no inertia compensation, so it tracks a moving target only through its error, and with
the paper's K0 = 200 N/m the simulated Panda lags a 0.20 m, 5 s circle by about 14 mm RMS. A superimposed
autonomous trajectory (the planner's x_d'') is known ahead, so its acceleration can be fed forward: the TCP
acceleration is J qdd + Jdot qd, and with qdd = M^-1 J^T Lambda (a_d - Jdot qd) it is a_d (for mu -> 0), with
no error needed to produce it. The full 6x6 Lambda (not its translation block) is used so that the angular
acceleration demanded is alpha (zero for a 3-vector) rather than whatever the translation would drag along; on
the circle the 3x3 translation-only variant barely helped, and Jdot qd (about as large as the circle's
centripetal acceleration) matters: RMS 14.5 -> 5.9 mm with both (the replica on the MuJoCo arm,
test_replica_on_mujoco). This does not touch the
FIC's stability argument, which is about the feedback part: the feedforward does not depend on the error, it is
an external bounded input (like the operator's force), and with mu > 0 it is bounded by |a_d| / mu near the
singularities. It is added before the postural optimisation, as part of tau_d, so every limit still holds
(and a limit that trades tracking trades the feedforward first, in the Gauss metric).
Joint friction compensation (beyond paper Eq. 7, optional: ``joint_damping_compensation``): tau_d + D qd_d, with D
the arm's viscous joint damping (robot.joint_damping, 0.5 N m s/rad: what the simulator applies; a real arm's
identified viscous friction goes there) and qd_d = M^-1 J^T Lambda xd_d the joint velocity of least kinetic
energy that moves the TCP at the desired twist (the dynamically consistent inverse; zero without a desired
twist). Why: Eq. 7 cancels C qd + G but not friction, and on the 0.20 m, 5 s circle D qd alone left the TCP about
5 mm behind x_d (with the inertial feedforward; measured in a one-process twin of the E1 scene). The friction of
the desired motion, not of the measured one: compensating D qd also cancels the arm's damping of every deviation,
and in the graph the operator's quick moves then overshot by 3 cm more; with D qd_d the twin's free-space RMS
error was 3.3 mm (4.0 with D qd, 9.2 with neither). Like the inertial feedforward it does not depend on the
error, and it goes into tau_d before the postural optimisation, so every limit still holds.
Bounded feedforward (``feedforward_limit``, optional): the force and the moment of Lambda a_d are clipped to
norms (F_lin, M_lin), the node passes the FIC's own F_max of translation and rotation. Why: a_d of a teleoperated
offset is an estimate (a difference quotient of delayed, jittery samples), and near a singularity an effective
mass of hundreds of kg turns a few m/s^2 of estimation noise into hundreds of newtons (an E2 trial with the
unbounded offset feedforward peaked at 562 N at the wrist; the same trial before the feedforward existed, 32 N). Bounded
by F_max, the feedforward can never push harder than the FIC itself may, which keeps the paper's bounded-force property
for the whole task-space command. The regularisation mu (``feedforward_regularisation``, default 1e-3 in 1/kg, 1/(kg
m^2) on the rotation rows) caps the effective mass of any task direction at 1/mu = 1000 kg: near a singularity, where J
M^-1 J^T loses rank, Lambda stays finite (a damped least-squares inverse), and away from one (the Panda's effective
masses are a few kg, eigenvalues of J M^-1 J^T above 0.1) it changes Lambda by less than 1 %.

Cost (the 1 kHz budget, docs/RESULTS.md): the tick validates every public input once (one sum of Python floats
per signal: NaN and Inf propagate into it; a desired rotation matrix equal to the last one checked is not
checked for orthonormality again), runs the per-axis FIC logic and the postural optimisation's admissibility
test on plain floats (one pass that also tells whether the measured state is inside its limits, which settles
the violation check), uses Pinocchio's frame-Jacobian pass, and leaves every report-only quantity (posture
torque, stored energy, kinetic energy, limit ratios, the arrays of the pose) to be computed when a
ReplicaCommand's property is read. On this interpreter a numpy call on a 7-vector costs about as much as a
7-element list comprehension (~4k instructions), so small vectors stay in whichever form the next step needs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray
from scipy.linalg.lapack import dposv  # a 6x6 Cholesky solve without numpy.linalg's per-call overhead

from .errors import FicInputError, finite_array, finite_floats, finite_scalar
from .limits import LIMIT_FLAGS, VIOLATION_TOLERANCE, LimitFlag, PandaLimits, violation_flags
from .postural_optimisation import VERDICT_INSIDE, PosturalOptimisation
from .posture import NullSpacePosture
from .quaternion import rotation_from_quaternion
from .robot_model import RobotModel, RobotState, checked_array
from .torque_slew import TorqueSlew

_ROTATION_TOLERANCE = 1e-6


def _limited_wrench(wrench: NDArray[np.float64], limit: tuple[float, float]) -> NDArray[np.float64]:
    """The wrench with its force and moment each scaled down to at most the given norms."""
    force_norm = math.sqrt(float(wrench[:3].dot(wrench[:3])))
    moment_norm = math.sqrt(float(wrench[3:].dot(wrench[3:])))
    if force_norm <= limit[0] and moment_norm <= limit[1]:
        return wrench
    wrench = wrench.copy()
    if force_norm > limit[0]:
        wrench[:3] *= limit[0] / force_norm
    if moment_norm > limit[1]:
        wrench[3:] *= limit[1] / moment_norm
    return wrench
_new_command = object.__new__  # a ReplicaCommand without its __init__, for the tick (see ReplicaController.command)
_IDENTITY3 = np.eye(3)
_ZERO3 = np.zeros(3)
_NO_LIMIT = LimitFlag.NONE

#: mu of the inertial feedforward's Lambda = (J M^-1 J^T + mu I)^-1 [1/kg, 1/(kg m^2)]: effective masses capped
#: at 1/mu = 1000 kg near singularities, < 1 % change where they are below 10 kg (module docstring).
DEFAULT_FEEDFORWARD_REGULARISATION = 1e-3


class TaskController(Protocol):
    """What the replica needs of PoseAttractor (the FIC) and LinearImpedance (the baseline).

    Both also offer ``snapshot()`` (the report values of the last tick, computed on read) and
    ``wrench_values`` (``wrench`` on floats the replica has validated); a controller without them works too,
    at the cost of reading its report values at each tick and of ``wrench``'s own input checks.
    """

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


@dataclass(slots=True, kw_only=True, eq=False)
class ReplicaCommand:
    """One tick of the replica: the torque to send and everything a status message or a report needs.

    The torque and the flags are computed by the tick; report-only quantities (posture torque, pose arrays,
    the controller's phase, latched errors and stored energy, the kinetic energy, the LimitStatus ratios) are
    properties computed from the tick's stored state on first access, so that a tick whose report nobody reads
    does not pay for them, and a command read later still reports its own tick. No equality by value (its
    fields are arrays): two commands are equal only if they are the same object.
    """

    torque: NDArray[np.float64]              # the command sent [N m] (7,): the law's, slewed (torque_slew.py)
    unshaped_torque: NDArray[np.float64]     # tau_d of Eq. 7 before the postural optimisation (7,)
    wrench: NDArray[np.float64]              # FIC(x~_R) [N, N m] (6,), base frame (= the controller's force)
    rotation_error: NDArray[np.float64]      # log(R_d R^T) [rad] (3,), base frame
    desired_rotation: NDArray[np.float64]    # R_d (3, 3)
    tcp_rotation: NDArray[np.float64]        # R (3, 3)
    limit_shaping: LimitFlag                 # limits that changed the command this tick
    limit_violations: LimitFlag              # limits the command or the measured state broke this tick
    torque_change: float                     # |tau - tau_d| [N m]
    tcp_speed: float                         # measured TCP speed [m/s]
    controller_name: str                     # "fic" or "linear"
    solved_qp: bool                          # the optimisation had to solve its QP this tick
    relaxed: bool                            # prediction constraints infeasible, softened
    guard_clipped: bool                      # the last-guard clip acted
    q: NDArray[np.float64]                   # measured joint positions [rad] (7,)
    qd: NDArray[np.float64]                  # measured joint velocities [rad/s] (7,)
    previous_torque: NDArray[np.float64] | None  # the command sent before this one (None for the first)
    control_period: float                    # the law's period [s]
    interval: float                          # time since the command before this one [s] (its rate bound)
    law_torque: NDArray[np.float64]          # the postural optimisation's output before the slew (7,)
    limits: PandaLimits
    feedforward_wrench: NDArray[np.float64] | None  # Lambda a_d [N, N m] (6,), None without a_d
    desired_position_values: list[float]     # x_d [m] as floats (``desired_position`` is the array)
    tcp_position: NDArray[np.float64]        # x_R [m] (3,)
    tracking_error_values: list[float]       # x_d - x_R [m] as floats (``tracking_error`` is the array)
    jacobian: NDArray[np.float64]            # J (6, 7) of this tick, LOCAL_WORLD_ALIGNED
    posture_joint_torque: NDArray[np.float64]  # tau_0, the posture torque before projection (7,)
    posture_task_force: NDArray[np.float64]  # Lambda J M^-1 tau_0 (6,): N^T tau_0 = tau_0 - J^T this
    controller_snapshot: object              # the controller's phase, latched_max_error, stored_energy of this tick
    # (``port_values()`` for a passivity observer when the controller offers it)
    dynamics: tuple[pin.Model, pin.Data]     # a Data of the replica's own, for the kinetic energy on read
    _cache: dict[str, object] | None = field(default=None, init=False, repr=False)  # made on the first report read

    def clear_report_cache(self) -> None:
        """No report value computed yet (a command whose fields are set one by one: ReplicaController.command)."""
        self._cache = None

    def _cached(self, name: str, compute):
        cache = self._cache
        if cache is None:
            cache = self._cache = {}
        if name not in cache:
            cache[name] = compute()
        return cache[name]

    @property
    def posture_torque(self) -> NDArray[np.float64]:
        """tau_posture (7,), in the task's dynamically consistent null space."""
        return self._cached("posture_torque",
                            lambda: self.posture_joint_torque - self.jacobian.T.dot(self.posture_task_force))

    @property
    def feedforward_torque(self) -> NDArray[np.float64]:
        """J^T Lambda a_d [N m] (7,): the inertial feedforward (zeros without a desired acceleration)."""
        if self.feedforward_wrench is None:
            return np.zeros(self.torque.shape)
        return self._cached("feedforward_torque", lambda: self.jacobian.T.dot(self.feedforward_wrench))

    @property
    def tracking_error(self) -> NDArray[np.float64]:
        """x_d - x_R [m] (3,)."""
        return self._cached("tracking_error", lambda: np.array(self.tracking_error_values))

    @property
    def desired_position(self) -> NDArray[np.float64]:
        """x_d [m] (3,)."""
        return self._cached("desired_position", lambda: np.array(self.desired_position_values))

    @property
    def controller_force(self) -> NDArray[np.float64]:
        return self.wrench

    @property
    def phase(self) -> NDArray:
        """Per-axis FIC phase (6,) at this tick."""
        return self._cached("phase", lambda: np.asarray(self.controller_snapshot.phase))

    @property
    def latched_max_error(self) -> NDArray[np.float64]:
        """(6,) at this tick."""
        return self._cached("latched_max_error",
                            lambda: np.asarray(self.controller_snapshot.latched_max_error, dtype=float))

    @property
    def stored_energy(self) -> NDArray[np.float64]:
        """Energy in the controller's springs (6,) [J] at this tick."""
        return self._cached("stored_energy", lambda: np.asarray(self.controller_snapshot.stored_energy, dtype=float))

    @property
    def kinetic_energy(self) -> float:
        """0.5 qd^T M qd [J]."""
        def compute() -> float:
            model, data = self.dynamics
            return float(pin.computeKineticEnergy(model, data, self.q, self.qd))
        return self._cached("kinetic_energy", compute)

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
        """|tau_i - tau_prev_i| / (torque-rate limit * the interval since it) (7,) of the torque sent; zeros for
        the first command."""
        if self.previous_torque is None:
            return np.zeros_like(self.torque)
        return np.abs(self.torque - self.previous_torque) / (self.limits.torque_rate * self.interval)

    @property
    def joint_velocity_ratio(self) -> NDArray[np.float64]:
        """|qd_i| / velocity limit_i, measured (7,)."""
        return np.abs(self.qd) / self.limits.joint_velocity_array

    @property
    def joint_position_margin(self) -> NDArray[np.float64]:
        """Distance of each joint to its nearest URDF limit [rad] (7,); negative beyond it."""
        return np.minimum(self.q - self.limits.lower_array, self.limits.upper_array - self.q)


class _EagerSnapshot:
    """For a controller without ``snapshot()``: its report values read at the tick."""

    __slots__ = ("phase", "latched_max_error", "stored_energy")

    def __init__(self, controller) -> None:
        self.phase = np.asarray(controller.phase)
        self.latched_max_error = np.asarray(controller.latched_max_error, dtype=float)
        self.stored_energy = np.asarray(controller.stored_energy, dtype=float)


def _determinant(matrix: NDArray[np.float64]) -> float:
    (a, b, c), (d, e, f), (g, h, i) = matrix.tolist()  # 3x3 by hand: numpy.linalg.det's overhead is ~10 us
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def _rotation_matrix_is_valid(rows: list[list[float]]) -> bool:
    """R^T R = I within _ROTATION_TOLERANCE elementwise and det R > 0, on floats (a 3x3 in numpy costs more in
    call overhead than in arithmetic)."""
    (a, b, c), (d, e, f), (g, h, i) = rows
    deviation = max(abs(a * a + d * d + g * g - 1.0), abs(b * b + e * e + h * h - 1.0),
                    abs(c * c + f * f + i * i - 1.0), abs(a * b + d * e + g * h), abs(a * c + d * f + g * i),
                    abs(b * c + e * f + h * i))
    determinant = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    return deviation <= _ROTATION_TOLERANCE and determinant > 0.0


def _desired_rotation(value: ArrayLike) -> NDArray[np.float64]:
    """A checked copy of the desired rotation (a 3x3 matrix, or a quaternion x, y, z, w)."""
    if type(value) is np.ndarray and value.shape == (3, 3) and value.dtype == np.float64:
        rows = value.tolist()
        if math.isfinite(sum(rows[0]) + sum(rows[1]) + sum(rows[2])):  # NaN/Inf propagate into the sum
            if not _rotation_matrix_is_valid(rows):
                raise FicInputError(f"desired_rotation must be a rotation matrix (orthonormal, det +1), got {value}")
            return value.copy()
    array = np.asarray(value, dtype=float)
    if array.shape == (4,):
        return rotation_from_quaternion(array)
    rotation = checked_array("desired_rotation", array, (3, 3))
    if np.abs(rotation.T @ rotation - _IDENTITY3).max() > _ROTATION_TOLERANCE or _determinant(rotation) <= 0.0:
        raise FicInputError(f"desired_rotation must be a rotation matrix (orthonormal, det +1), got {rotation}")
    return rotation.copy()


def _desired_acceleration(value: ArrayLike) -> NDArray[np.float64]:
    """The desired TCP acceleration as a checked (6,) [a; alpha]; a (3,) a is extended with alpha = 0."""
    array = np.asarray(value, dtype=float) if type(value) is not np.ndarray or value.dtype != np.float64 else value
    if array.shape == (3,):
        array = np.concatenate((array, _ZERO3))
    return checked_array("desired_acceleration", array, (6,))


class ReplicaController:
    """Paper Eq. 7 with a null-space posture, then the postural optimisation, for one control tick at a time.

    ``control_period`` is the time between two ``command`` calls: it sets the torque-rate box (rate * period)
    and the prediction step. The first command after construction or ``reset()`` has no torque-rate bound
    (there is no previous command to rate against).

    The torque it returns is the torque to send: the law's output approached from the last torque sent at the
    torque-rate limit over the time since it (``TorqueSlew``; ``command_period`` is the shortest such time, the
    joint-state period), and ``held_torque`` gives the torque to send at a joint state between two control
    ticks. So the limit flags, the counters and the LimitStatus ratios describe what goes to the robot, and
    |tau_k - tau_(k-1)| <= torque_rate * dt_k over the whole sequence sent.
    """

    def __init__(self, robot: RobotModel, controller: TaskController, *, limits: PandaLimits | None = None,
                 posture: NullSpacePosture | None = None, control_period: float = 0.001,
                 optimisation: PosturalOptimisation | None = None,
                 feedforward_regularisation: float = DEFAULT_FEEDFORWARD_REGULARISATION,
                 joint_damping_compensation: bool = False,
                 feedforward_limit: tuple[float, float] | None = None,
                 command_period: float | None = None) -> None:
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
        self._slew = TorqueSlew(self.limits.torque_rate,
                                self.control_period if command_period is None else command_period)
        self._target: NDArray[np.float64] | None = None  # the law's last output, approached between ticks
        self._held_position: NDArray[np.float64] | None = None
        self._held_rotation: NDArray[np.float64] | None = None
        self.ticks = 0              # cumulative counters (LimitStatus ticks, shaped_ticks, violation_ticks)
        self.shaped_ticks = 0
        self.violation_ticks = 0
        rate_step = np.full(robot.dof, self.limits.torque_rate * self.control_period)
        self._bounds = np.concatenate((self.limits.torque_array, rate_step, self.limits.joint_velocity_array))
        self._first_bounds = np.concatenate((self.limits.torque_array, self.limits.joint_velocity_array))
        #: mu of the feedforward's Lambda = (J M^-1 J^T + mu I)^-1 (module docstring).
        self.feedforward_regularisation = finite_scalar("feedforward_regularisation", feedforward_regularisation,
                                                        minimum=0.0, minimum_inclusive=False)
        self._feedforward_matrix = self.feedforward_regularisation * np.eye(6)
        #: Add D qd_d, the viscous joint friction of the desired motion, to tau_d (module docstring).
        self.joint_damping_compensation = bool(joint_damping_compensation)
        #: Norm bounds [N, N m] of the feedforward wrench's force and moment (module docstring); None: unbounded.
        self.feedforward_limit = None if feedforward_limit is None else (
            finite_scalar("feedforward_limit[0]", feedforward_limit[0], minimum=0.0),
            finite_scalar("feedforward_limit[1]", feedforward_limit[1], minimum=0.0))
        self._torque_values = self.limits.torque_array.tolist()
        self._velocity_values = self.limits.joint_velocity_array.tolist()
        self._lower_values = self.limits.lower_array.tolist()
        self._upper_values = self.limits.upper_array.tolist()
        self._previous_values: list[float] | None = None
        self._tcp_speed_bound = self.limits.tcp_speed + VIOLATION_TOLERANCE
        # An unshaped tau_d passed the optimisation's torque and torque-rate tests: with the same limits (and a
        # rate step no larger than the violation check's), it is inside the violation check's torque and rate limits
        # too.
        self._verdict_covers_violations = self.optimisation.limits == self.limits and \
            self.optimisation.rate_step <= self.limits.torque_rate * self.control_period + VIOLATION_TOLERANCE
        self._valid_rotation_rows: list[list[float]] | None = None  # the last desired rotation matrix checked
        # T of the optimisation's velocity predictions, fixed with it at construction (its own fast path keeps
        # the same copy): the tick's TCP prediction must use the same horizon as the optimisation.
        self._horizon = self.optimisation.horizon
        # A Pinocchio Data of the commands' own, to compute a command's kinetic energy when it is read (the
        # robot's Data belongs to the next tick by then).
        self._report_dynamics = (robot.model, robot.model.createData())

    @property
    def previous_torque(self) -> NDArray[np.float64] | None:
        """The last command (None before the first)."""
        previous = self._slew.last
        return None if previous is None else previous.copy()

    def reset(self, previous_torque: ArrayLike | None = None) -> None:
        """Forget the controller state and the last desired pose; optionally state the torque now applied."""
        self.controller.reset()
        torque = None if previous_torque is None else \
            finite_array("previous_torque", previous_torque, (self.robot.dof,)).copy()
        self._slew.reset(torque)
        self._target = torque
        self._previous_values = None if torque is None else torque.tolist()
        self._held_position = None
        self._held_rotation = None

    def state_sent(self, torque: ArrayLike, time: float | None) -> None:
        """State the torque that went out in place of the last command's (the replica loop's blend from its hold,
        fic_core.loop_health): the torque-rate bound and the violation check continue from it."""
        torque = finite_array("torque sent", torque, (self.robot.dof,)).copy()
        self._slew.reset(torque, time if time is not None else self._slew.last_time)
        self._previous_values = torque.tolist()

    def late_tick(self, late: float) -> None:
        """The next command is for a torque held ``late`` = T - T_0 seconds beyond the nominal period
        (fic_core.sampled_spring_damping): passed to a task controller that damps its sampled springs (the FIC's
        PoseAttractor); a baseline with its own damping has nothing to give back."""
        late_tick = getattr(self.controller, "late_tick", None)
        if late_tick is not None:
            late_tick(late)

    def continue_from(self, other: ReplicaController) -> None:
        """Take over from the controller this one replaces (a change of parameters at run time): the torque it
        sent last (so the torque-rate bound holds across the swap), its target, and its cumulative counters.
        The task controller's own state starts afresh (its profile may have changed)."""
        last = other._slew.last
        self._slew.reset(last, other._slew.last_time)
        self._target = None if other._target is None else other._target.copy()
        self._previous_values = None if last is None else last.tolist()
        self.ticks, self.shaped_ticks, self.violation_ticks = other.ticks, other.shaped_ticks, other.violation_ticks

    def held_torque(self, time: float | None = None) -> NDArray[np.float64] | None:
        """The torque to send at a joint state between control ticks (joint-state time ``time``; None:
        unknown): the law's last output approached at the torque-rate limit. None before the first tick."""
        if self._target is None:
            return self.previous_torque
        torque = self._slew.step(self._target, time)
        self._previous_values = torque.tolist()
        return torque.copy()

    def repeat_torque(self) -> NDArray[np.float64] | None:
        """The last torque sent, again (a joint state that could not be used: nothing moves)."""
        return self.previous_torque

    def command(self, q: ArrayLike, qd: ArrayLike, desired_position: ArrayLike, desired_rotation: ArrayLike,
                desired_twist: ArrayLike | None = None,
                desired_acceleration: ArrayLike | None = None, time: float | None = None) -> ReplicaCommand:
        """The torque for state (q, qd) toward the desired TCP pose (rotation: 3x3 matrix or quaternion x,y,z,w).

        ``desired_twist`` (6,) is the desired TCP twist [v; w] in the base frame (zero if omitted); the twist
        error handed to the controller is desired minus measured. ``desired_acceleration`` is the desired TCP
        acceleration in the base frame, (6,) [a; alpha] or (3,) a (then alpha = 0); if given, the inertial
        feedforward J^T Lambda a_d is added to tau_d before the postural optimisation (module docstring).
        ``time``: the joint-state time the command answers, for the slew's interval (None: one command period).
        Raises FicInputError on NaN/Inf or bad shapes, before any state changes.

        One tick in four parts: the task wrench (``_task_wrench``), Eq. 7's tau_d (``_desired_torque``), the
        postural optimisation (``_shaped``), the torque sent and its limit check (``_sent``); then the report.
        """
        desired_position = finite_floats("desired_position", desired_position, 3)
        desired_rotation = self._desired_rotation(desired_rotation)
        desired_twist = None if desired_twist is None else finite_floats("desired_twist", desired_twist, 6)
        if desired_acceleration is not None:
            desired_acceleration = _desired_acceleration(desired_acceleration)
        state = self.robot.update(q, qd)  # validates q and qd
        self._held_position = desired_position
        self._held_rotation = desired_rotation
        twist = state.tcp_twist.tolist()
        wrench, position_error, rotation_error = self._task_wrench(state, twist, desired_position, desired_rotation,
                                                                   desired_twist)
        margins = [value - lower if value - lower < upper - value else upper - value
                   for value, lower, upper in zip(state.q_values, self._lower_values, self._upper_values)]
        desired_torque, drive, posture_joint_torque, posture_task_force, feedforward_wrench = self._desired_torque(
            state, wrench, margins, desired_twist, desired_acceleration)
        previous = self._slew.last   # the torque sent last: the rate box is around it
        torque, torque_values, flags, torque_change, solved_qp, relaxed, guard_clipped, verdict = self._shaped(
            state, twist, wrench, desired_torque, drive, margins)
        law_torque = torque
        torque, flags, violations, interval, tcp_speed = self._sent(state, twist, torque, torque_values, flags,
                                                                    verdict, margins, previous, time)

        snapshot = getattr(self.controller, "snapshot", None)
        # Every field of ReplicaCommand by name, as its keyword constructor takes them, but set on a bare instance:
        # CPython passes a call with more than 15 keyword arguments through a dict (about 3.5 us here, 6 % of the
        # tick), while these stores cost what the old positional constructor did (test_replica checks that the
        # tick sets every field).
        command = _new_command(ReplicaCommand)
        command.torque = torque
        command.unshaped_torque = desired_torque
        command.wrench = wrench
        command.rotation_error = rotation_error
        command.desired_rotation = desired_rotation
        command.tcp_rotation = state.tcp_rotation
        command.limit_shaping = flags
        command.limit_violations = violations
        command.torque_change = torque_change
        command.tcp_speed = tcp_speed
        command.controller_name = self.controller.controller_name
        command.solved_qp = solved_qp
        command.relaxed = relaxed
        command.guard_clipped = guard_clipped
        command.q = state.q
        command.qd = state.qd
        command.previous_torque = previous
        command.control_period = self.control_period
        command.interval = interval
        command.law_torque = law_torque
        command.limits = self.limits
        command.feedforward_wrench = feedforward_wrench
        command.desired_position_values = desired_position
        command.tcp_position = state.tcp_position
        command.tracking_error_values = position_error
        command.jacobian = state.tcp_jacobian
        command.posture_joint_torque = posture_joint_torque
        command.posture_task_force = posture_task_force
        command.controller_snapshot = snapshot() if snapshot is not None else _EagerSnapshot(self.controller)
        command.dynamics = self._report_dynamics
        command.clear_report_cache()
        return command

    def _task_wrench(self, state: RobotState, twist: list[float], desired_position: list[float],
                     desired_rotation: NDArray[np.float64],
                     desired_twist: list[float] | None) -> tuple[NDArray[np.float64], list[float], NDArray[np.float64]]:
        """The task controller's wrench (Eq. 2 for the FIC) on the pose and twist errors of the TCP: (wrench,
        position error, rotation error as a rotation vector)."""
        x, y, z = state.tcp_position.tolist()
        position_error = [desired_position[0] - x, desired_position[1] - y, desired_position[2] - z]
        rotation_error = pin.log3(desired_rotation.dot(state.tcp_rotation.T))
        if desired_twist is None:
            twist_error = [-value for value in twist]
        else:
            twist_error = [target - actual for target, actual in zip(desired_twist, twist)]
        controller = self.controller
        wrench_values = getattr(controller, "wrench_values", None)
        if wrench_values is not None:  # PoseAttractor, LinearImpedance: on the floats validated above
            wrench = np.array(wrench_values(position_error, rotation_error.tolist(), twist_error))
        else:
            wrench = np.asarray(controller.wrench(np.array(position_error), rotation_error, np.array(twist_error)),
                                dtype=float)
            if wrench.shape != (6,):
                raise FicInputError(f"the controller returned a mis-shaped wrench: {wrench}")
        return wrench, position_error, rotation_error

    def _desired_torque(self, state: RobotState, wrench: NDArray[np.float64], margins: list[float],
                        desired_twist: list[float] | None, desired_acceleration: NDArray[np.float64] | None
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                                   NDArray[np.float64], NDArray[np.float64] | None]:
        """Eq. 7: tau_d = C qd + G + J^T (FIC(x~_R) [+ Lambda a_d]) + tau_posture [+ D qd_d]. Returns (tau_d, the
        drive tau_d - (C qd + G), the posture's joint torque, its task force, the feedforward wrench or None)."""
        robot = self.robot
        jacobian = state.tcp_jacobian
        minv = state.mass_matrix_inverse
        posture = self.posture
        # Null-space posture, N^T tau_0 = tau_0 - J^T Lambda J M^-1 tau_0 (posture.py), with J M^-1 shared.
        posture_joint_torque = np.array(posture.joint_torque_values(state.q_values, state.qd_values, state.q,
                                                                    min(margins)))
        j_minv = jacobian.dot(minv)
        task_inverse_inertia = j_minv.dot(jacobian.T)  # J M^-1 J^T
        posture_task_force = posture.apply_task_inertia(task_inverse_inertia, j_minv.dot(posture_joint_torque))
        task_force = wrench - posture_task_force
        feedforward_wrench = None
        if desired_acceleration is not None:
            feedforward_wrench = self._feedforward_wrench(task_inverse_inertia,
                                                          desired_acceleration - robot.tcp_bias_acceleration)
            if self.feedforward_limit is not None:
                feedforward_wrench = _limited_wrench(feedforward_wrench, self.feedforward_limit)
            task_force += feedforward_wrench
        # tau_d - (C qd + g) = J^T (FIC [+ Lambda a_d] - Lambda J M^-1 tau_0) + tau_0.
        drive = task_force.dot(jacobian)
        drive += posture_joint_torque
        if self.joint_damping_compensation and desired_twist is not None:
            # + D qd_d, qd_d = M^-1 J^T Lambda xd_d: the friction of the desired motion (module docstring).
            desired_joint_velocity = j_minv.T.dot(self._feedforward_wrench(task_inverse_inertia,
                                                                           np.array(desired_twist)))
            # Bounded by the friction at the joints' own speed limits: a faster desired motion is one the arm
            # cannot make, so its friction is never there to cancel (|D qd_d| <= D qd_max per joint).
            velocity_limit = self.limits.joint_velocity_array
            drive += robot.joint_damping * np.minimum(np.maximum(desired_joint_velocity, -velocity_limit),
                                                      velocity_limit)  # np.clip, without its dispatch
        return state.nonlinear_effects + drive, drive, posture_joint_torque, posture_task_force, feedforward_wrench

    def _shaped(self, state: RobotState, twist: list[float], wrench: NDArray[np.float64],
                desired_torque: NDArray[np.float64], drive: NDArray[np.float64], margins: list[float]
                ) -> tuple[NDArray[np.float64], list[float], LimitFlag, float, bool, bool, bool, int]:
        """The postural optimisation of tau_d: (torque, its values, the limit flags, the torque change, solved by
        the QP, relaxed, guard-clipped, the optimisation's verdict on tau_d). FicInputError for a tau_d not
        finite."""
        # Postural optimisation: M qdd = tau - (C qd + g) - D qd in the prediction (the arm's joint damping).
        # Its fast path first, on floats: the acceleration under tau_d, and the TCP velocity extrapolated T ahead.
        optimisation = self.optimisation
        horizon = self._horizon
        qd = state.qd
        minv = state.mass_matrix_inverse
        jacobian = state.tcp_jacobian
        damping = self.robot.joint_damping
        acceleration = minv.dot(drive - damping * qd)
        tcp_acceleration = jacobian[:3].dot(acceleration).tolist()
        tcp_ahead = [velocity + horizon * value for velocity, value in zip(twist, tcp_acceleration)]
        tcp_ahead_squared = tcp_ahead[0] * tcp_ahead[0] + tcp_ahead[1] * tcp_ahead[1] + tcp_ahead[2] * tcp_ahead[2]
        previous_values = self._previous_values
        desired_values = desired_torque.tolist()
        # One check for every term (NaN/Inf propagate into the sum; a sum that overflowed is checked in full).
        if not math.isfinite(sum(desired_values)) and not np.isfinite(desired_torque).all():
            if not np.isfinite(wrench).all():
                raise FicInputError(f"the controller returned a non-finite wrench: {wrench}")
            raise FicInputError(f"the desired torque is not finite: {desired_torque}")
        verdict = optimisation.admissible(desired_values, previous_values, state.q_values, state.qd_values,
                                          acceleration.tolist(), tcp_ahead_squared, margins)
        if verdict:
            # tau_d breaks no constraint of the optimisation: it is the command, unshaped (as shape() would say).
            return desired_torque.copy(), desired_values, _NO_LIMIT, 0.0, False, False, False, verdict
        # The verdict already ran shape()'s fast-path tests (on these floats): straight to the flags and the QP.
        torque, flags, torque_change, solved_qp, relaxed, guard_clipped = optimisation.shape_rejected(
            desired_torque, desired_values, previous_values, state.q_values, qd, state.qd_values,
            state.nonlinear_effects + damping * qd, minv, jacobian[:3])
        if not solved_qp:
            torque = desired_torque.copy()
        return torque, torque.tolist(), LIMIT_FLAGS[flags], torque_change, solved_qp, relaxed, guard_clipped, verdict

    def _sent(self, state: RobotState, twist: list[float], law_torque: NDArray[np.float64],
              torque_values: list[float], flags: LimitFlag, verdict: int, margins: list[float],
              previous: NDArray[np.float64] | None,
              time: float | None) -> tuple[NDArray[np.float64], LimitFlag, LimitFlag, float, float]:
        """The torque sent: the law's, slewed from the last one sent over the time since it (torque_slew.py), and
        the limits it breaks, counted. Returns (torque, flags with TORQUE_RATE if slewed, violations, the
        interval since the last torque sent, the TCP speed)."""
        self._target = law_torque
        interval = self._slew.interval(time)
        torque = self._slew.step(law_torque, time)
        sent_values = torque.tolist()
        slewed = sent_values != torque_values
        if slewed:
            flags = LimitFlag(int(flags) | LimitFlag.TORQUE_RATE.value)
            torque_values = sent_values
        else:
            torque = law_torque
        velocity = twist[:3]
        tcp_speed = math.sqrt(velocity[0] * velocity[0] + velocity[1] * velocity[1] + velocity[2] * velocity[2])
        # An unshaped tau_d with |qd| and q inside their limits (the verdict says so, with the same limits) breaks
        # none of the limits unless the TCP speed does (when it is sent as it is, a full period after the last
        # command); otherwise the full check on floats, against the interval since the last command sent.
        full_interval = interval >= self.control_period * (1.0 - 1e-9)
        if (tcp_speed <= self._tcp_speed_bound
                if verdict >= VERDICT_INSIDE and self._verdict_covers_violations and not slewed and full_interval
                else self._violation_free(torque_values, state.qd_values, margins, tcp_speed, interval)):
            violations = _NO_LIMIT
        else:
            violations = self._violations(previous, torque, state.qd, np.array(margins), tcp_speed, interval)
        self._previous_values = torque_values
        self.ticks += 1
        if flags:
            self.shaped_ticks += 1
        if violations:
            self.violation_ticks += 1
        return torque, flags, violations, interval, tcp_speed

    def _desired_rotation(self, value: ArrayLike) -> NDArray[np.float64]:
        """``_desired_rotation``, whose orthonormality test is skipped for a matrix equal to the last one that
        passed it (a held orientation is the same matrix tick after tick)."""
        if type(value) is np.ndarray and value.shape == (3, 3) and value.dtype == np.float64:
            rows = value.tolist()
            if rows == self._valid_rotation_rows:  # NaN never compares equal
                return value.copy()
            rotation = _desired_rotation(value)
            self._valid_rotation_rows = rows
            return rotation
        return _desired_rotation(value)

    def _feedforward_wrench(self, task_inverse_inertia: NDArray[np.float64],
                            desired_acceleration: NDArray[np.float64]) -> NDArray[np.float64]:
        """Lambda a with Lambda = (J M^-1 J^T + mu I)^-1, by Cholesky (positive definite for mu > 0)."""
        matrix = task_inverse_inertia + self._feedforward_matrix
        _, solution, info = dposv(matrix, desired_acceleration)
        if info != 0:  # only if J M^-1 J^T were not positive semidefinite (a corrupt model)
            solution = np.linalg.lstsq(matrix, desired_acceleration, rcond=None)[0]
        return solution

    def _violation_free(self, torque: list[float], qd: list[float], position_margin: list[float],
                        tcp_speed: float, interval: float) -> bool:
        """No limit violation (docs/CONTROL_LAWS.md; the common tick), on floats; ``_violations`` names them
        otherwise."""
        limits = self.limits
        tolerance = VIOLATION_TOLERANCE
        if tcp_speed > limits.tcp_speed + tolerance:
            return False
        previous = self._previous_values
        if previous is not None:
            step = limits.torque_rate * interval + tolerance
            for value, before in zip(torque, previous):
                if not abs(value - before) <= step:
                    return False
        # The excess over each limit against the slack, as limits.violation_flags computes it: "|x| <= limit +
        # slack" rounds the sum and called fl(limit + 1e-9) inside, which limits.py flags (one float per limit).
        for value, torque_limit, velocity, velocity_limit, margin in zip(
                torque, self._torque_values, qd, self._velocity_values, position_margin):
            if not (abs(value) - torque_limit <= tolerance and abs(velocity) - velocity_limit <= tolerance
                    and margin >= -tolerance):
                return False
        return True

    def _violations(self, previous: NDArray[np.float64] | None, torque: NDArray[np.float64],
                    qd: NDArray[np.float64], position_margin: NDArray[np.float64], tcp_speed: float,
                    interval: float) -> LimitFlag:
        """The limit-violation flags (docs/CONTROL_LAWS.md), with one fused test for the common all-clear tick."""
        limits = self.limits
        if previous is None:
            excess = (np.abs(np.concatenate((torque, qd))) - self._first_bounds).max()
        else:
            bounds = self._bounds if interval == self.control_period else np.concatenate(
                (self.limits.torque_array, np.full(self.robot.dof, limits.torque_rate * interval),
                 self.limits.joint_velocity_array))
            excess = (np.abs(np.concatenate((torque, torque - previous, qd))) - bounds).max()
        if excess <= VIOLATION_TOLERANCE and position_margin.min() >= -VIOLATION_TOLERANCE \
                and tcp_speed <= limits.tcp_speed + VIOLATION_TOLERANCE:
            return LimitFlag.NONE
        return violation_flags(previous, torque, self.robot.q, qd, tcp_speed, interval, limits)

    def hold(self, q: ArrayLike, qd: ArrayLike, time: float | None = None) -> ReplicaCommand:
        """A safe hold: keep the last desired pose (or, before any, the current TCP pose), zero desired twist.

        The same law and the same limits as ``command``; only the target stops moving.
        """
        if self._held_position is None or self._held_rotation is None:
            self.robot.update(q, qd)
            self._held_position = self.robot.tcp_position.tolist()
            self._held_rotation = self.robot.tcp_rotation.copy()
        return self.command(q, qd, self._held_position, self._held_rotation, time=time)
