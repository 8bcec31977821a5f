"""The postural optimisation: keep the replica's torque inside the Panda's limits by trading tracking accuracy.

The paper's headline feature (Sec. I, point 1) without a formula in the paper; our design (docs/CONTROL_LAWS.md).

Each tick, given the desired torque tau_d of Eq. 7 (compensation + J^T FIC + null-space posture), solve

    minimise    1/2 (tau - tau_d)^T M^-1 (tau - tau_d)                           (Gauss's least constraint)
    subject to  max(-tau_max, tau_prev - rate*dt) <= tau <= min(tau_max, tau_prev + rate*dt)      (hard)
                -v_max <= qd + T qdd(tau) <= v_max                               (joint velocity, horizon T)
                v_brake_lo(q) <= qd + dt qdd(tau) <= v_brake_hi(q)               (braking curve, next sample)
                q_min <= q + dt (qd + dt qdd(tau)) <= q_max                      (next sample inside the range)
                u^T J_v (qd + T qdd(tau)) <= v_tcp_max                           (TCP speed, cutting planes)
    with        qdd(tau) = M^-1 (tau - C qd - g - D qd)                          (predicted by the model)

- Objective: (tau - tau_d)^T M^-1 (tau - tau_d) = (qdd - qdd_d)^T M (qdd - qdd_d): the admissible motion closest
  to the commanded one in the kinetic-energy metric. What is traded is the motion, not an accidental split of
  the torque: a heavy shoulder and a light wrist are weighed by what their torque does.
- Limits are constraints, strictly above tracking. Torque and torque rate are box bounds on tau, always hard.
  The others are predictions, so they can be infeasible (a joint already past a limit, a contact pushing the arm,
  the torque-rate box too narrow to brake in one tick): then the QP is solved again with them as daqp soft
  constraints (minimal violation), and tau stays in the hard box.
- Velocity limits use a horizon T = max(velocity_horizon, dt): the velocity extrapolated T ahead must be in
  bounds, i.e. qdd <= (v_max - qd) / T. The limit is approached exponentially (time constant T), which keeps the
  braking compatible with the 1000 N m/s torque-rate limit, and the one-tick prediction qd + dt qdd is a convex
  combination of qd and the horizon velocity, so it is within bounds too.
- Joint position: a braking curve on the next sample's velocity, v_b L + v_b^2 / (2 a_brake) = q_max - q, so the
  joint can always still stop before its limit at the deceleration a_brake reached after a lag L (the horizon
  T plus the torque ramp at the rate limit, 20 ms); and the next sample must not cross it:
  q + dt (qd + dt qdd) <= q_max. (An exponential approach on the horizon, as for the velocity limit, lags the
  shrinking braking speed and overshoots the limit.) All bound the same qdd, so the tightest is kept: still 7
  two-sided rows. Past a limit the bound becomes a return velocity (q_max - q) / T < 0, on the horizon.
- TCP speed |J_v qd| <= 1.7 m/s is a cone; it is enforced by up to ``tcp_cuts`` linear cuts along the predicted
  TCP velocity, placed 0.1 % inside the limit (outer approximation refined until the prediction is inside).
- Fast path: when tau_d satisfies every constraint the QP is not built: tau = tau_d exactly, nothing flagged.
  The test runs on floats; a joint with |qd| <= v_max farther from its limits than the braking bound can reach
  only needs its velocity bounds (the others cannot be the tighter ones there). Past it, the flags, the box and
  the active-set report are also computed on floats, per joint (``_shape_values``).
- Last guard: the result is clipped into the hard torque/torque-rate box whatever the solver returned (a solver
  failure falls back to clipping tau_d); a clip larger than 1e-9 N m is counted in ``guard_clips``.
- Report: ``flags`` names the limits that shaped the command: those the unshaped tau_d broke, plus those whose
  constraint is active (non-zero multiplier) at the solution.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import daqp
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import FicInputError, finite_array, finite_scalar
from .limits import LIMIT_FLAGS, LimitFlag, PandaLimits

#: Half the Franka datasheet joint acceleration limits [rad/s^2]: the deceleration we count on to stop a joint
#: before its position limit.
DEFAULT_BRAKING_DECELERATION = (7.5, 3.75, 5.0, 6.25, 7.5, 10.0, 10.0)

#: Time for the torque to reach the braking deceleration at the torque-rate limit [s] (a * I / rate with
#: I up to about 2.5 kg m^2 for the shoulder of an outstretched arm).
BRAKING_TORQUE_RAMP = 0.02

_INFINITY = 1e30
_SENSE_INEQUALITY = 0
_SENSE_SOFT = 8
_EXIT_INFEASIBLE = -1
_MULTIPLIER_TOLERANCE = 1e-9
_TCP_RELATIVE_TOLERANCE = 1e-6  # the cone is met to this relative accuracy by the cutting planes
# The cuts sit this fraction inside the limit, so that once two consecutive cut directions are within ~5 degrees
# of each other the polytope's corner is inside the cone (1 / cos(2.5 deg) < 1 / (1 - 1e-3)).
_TCP_CUT_SHRINK = 1e-3
# The flags as plain ints inside the optimisation (IntFlag's operators cost microseconds each); ShapedTorque
# gets a LimitFlag.
_NONE = 0
_TORQUE = LimitFlag.TORQUE.value
_TORQUE_RATE = LimitFlag.TORQUE_RATE.value
_JOINT_VELOCITY = LimitFlag.JOINT_VELOCITY.value
_JOINT_POSITION = LimitFlag.JOINT_POSITION.value
_TCP_SPEED = LimitFlag.TCP_SPEED.value
_GUARD_TOLERANCE = 1e-9  # [N m] clips below this are solver round-off, not a guard action
# A joint this much farther from its position limits than ``_free_room`` (and with |qd| <= v_max) has its
# acceleration bounds set by the velocity limit alone: the braking and next-sample bounds are then looser by far
# more than their rounding (``_joint_bounds``'s shortcut; the exact comparison would give the same answer).
_FREE_ROOM_GUARD = 1e-6  # [rad]
#: ``PosturalOptimisation.admissible``'s verdicts: each one above VERDICT_REJECTED passes tau_d unshaped.
VERDICT_REJECTED = 0    # tau_d breaks a constraint (or nearly): the flags and the QP decide
VERDICT_UNSHAPED = 1    # tau_d breaks none of the QP's constraints
VERDICT_INSIDE = 2      # and the measured |qd| and q are inside their limits


@dataclass(frozen=True)
class ShapedTorque:
    """Result of one postural-optimisation step."""

    torque: NDArray[np.float64]          # the command, inside the torque and torque-rate limits
    flags: LimitFlag                     # limits that shaped it (NONE: torque == desired torque)
    torque_change: float                 # |torque - desired torque| [N m]
    solved_qp: bool                      # False on the fast path
    relaxed: bool                        # the prediction constraints were infeasible and were softened
    guard_clipped: bool                  # the last-guard clip changed the solver's answer
    iterations: int                      # QP solver iterations (0 on the fast path)
    fast_path: bool = False              # tau_d in the box, |qd| within the velocity limits, joints far from
                                         # their position limits: the measured state is then inside too


class PosturalOptimisation:
    """Shapes a desired joint torque so that it respects ``limits`` (see the module docstring)."""

    def __init__(self, limits: PandaLimits, control_period: float, *, velocity_horizon: float = 0.05,
                 braking_deceleration: float | ArrayLike = DEFAULT_BRAKING_DECELERATION, tcp_cuts: int = 8,
                 iteration_limit: int = 200) -> None:
        self.limits = limits
        self.control_period = finite_scalar("control_period", control_period, minimum=0.0, minimum_inclusive=False)
        self.velocity_horizon = finite_scalar("velocity_horizon", velocity_horizon, minimum=0.0,
                                              minimum_inclusive=False)
        deceleration = np.broadcast_to(finite_array("braking_deceleration", braking_deceleration), (7,)).astype(float)
        if np.any(deceleration <= 0.0):
            raise FicInputError(f"braking_deceleration must be > 0, got {braking_deceleration}")
        self.braking_deceleration = deceleration
        if int(tcp_cuts) < 1:
            raise FicInputError(f"tcp_cuts must be >= 1, got {tcp_cuts}")
        self.tcp_cuts = int(tcp_cuts)
        self.iteration_limit = int(iteration_limit)
        #: Delay before the braking deceleration is reached: the horizon (velocities approach their bound with time
        #: constant T) plus the torque ramp at the torque-rate limit (a * I / rate, about 20 ms for the heaviest
        #: joint at its braking deceleration).
        self._braking_lag = self.horizon + BRAKING_TORQUE_RAMP
        # Beyond this distance to a position limit the braking bound cannot be tighter than the velocity limit.
        v_max = limits.joint_velocity_array
        self._free_room = np.maximum(v_max * v_max / (2.0 * deceleration) + v_max * self._braking_lag,
                                     v_max * self.control_period)
        # The fast-path bounds as Python floats (``_admits_unshaped`` runs on floats).
        self._torque_values = limits.torque_array.tolist()
        self._negative_torque_values = (-limits.torque_array).tolist()
        self._velocity_values = v_max.tolist()
        self._free_room_values = self._free_room.tolist()
        #: The torque-rate box's half-width per control period [N m]: rate limit * period.
        self.rate_step = limits.torque_rate * self.control_period
        self._tcp_speed_squared = limits.tcp_speed * limits.tcp_speed
        self._lower_values = limits.lower_array.tolist()
        self._upper_values = limits.upper_array.tolist()
        self._deceleration_values = self.braking_deceleration.tolist()
        # Joint positions strictly between these are farther than _free_room (plus _FREE_ROOM_GUARD, which also
        # covers the rounding of the sums) from both position limits (``_joint_bounds``'s shortcut).
        self._free_low_values = [lower + room + _FREE_ROOM_GUARD
                                 for lower, room in zip(self._lower_values, self._free_room_values)]
        self._free_high_values = [upper - room - _FREE_ROOM_GUARD
                                  for upper, room in zip(self._upper_values, self._free_room_values)]
        self._horizon = self.horizon
        # The box-flag thresholds of ``_box_flags`` (a torque within 1e-9 N m of its bound sits on it).
        self._torque_edge_values = (limits.torque_array - 1e-9).tolist()
        self._rate_edge = self.rate_step - 1e-9
        # daqp's constraint senses: the 7 simple bounds always hard, the rows hard or (relaxed) soft; by row count.
        self._senses: dict[tuple[int, bool], NDArray[np.int32]] = {}
        self._far_from_limits = True  # the last ``_bounded`` found every joint far from its position limits
        self.qp_count = 0
        self.relaxed_count = 0
        self.guard_clips = 0

    @property
    def horizon(self) -> float:
        """T: the horizon of the velocity-like constraints [s]."""
        return max(self.velocity_horizon, self.control_period)

    def torque_box(self, previous_torque: NDArray[np.float64] | None
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Hard bounds on the command: torque limits intersected with the torque-rate step from the last command.

        If the last command was itself beyond a torque limit by more than one rate step, the torque limit wins.
        """
        torque_max = self.limits.torque_array
        if previous_torque is None:
            return -torque_max.copy(), torque_max.copy()
        step = self.limits.torque_rate * self.control_period
        lower = np.maximum(-torque_max, previous_torque - step)
        upper = np.minimum(torque_max, previous_torque + step)
        empty = lower > upper
        if empty.any():
            closest = np.clip(previous_torque, -torque_max, torque_max)
            lower = np.where(empty, closest, lower)
            upper = np.where(empty, closest, upper)
        return lower, upper

    def braking_velocity(self, q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(v_lo, v_hi): the joint velocities from which each joint still stops before its lower / upper position
        limit, braking at ``braking_deceleration`` a after a lag L (the horizon plus the torque ramp):
        v L + v^2 / 2a = room. Beyond a limit: a return speed room / T (v_hi < 0 past the upper limit)."""
        limits = self.limits
        a = self.braking_deceleration
        lag = self._braking_lag
        room_high = limits.upper_array - q
        room_low = q - limits.lower_array
        v_hi = np.where(room_high >= 0.0, a * (np.sqrt(lag * lag + 2.0 * np.maximum(room_high, 0.0) / a) - lag),
                        room_high / self.horizon)
        v_lo = -np.where(room_low >= 0.0, a * (np.sqrt(lag * lag + 2.0 * np.maximum(room_low, 0.0) / a) - lag),
                         room_low / self.horizon)
        return v_lo, v_hi

    def acceleration_bounds(self, q: NDArray[np.float64], qd: NDArray[np.float64]
                            ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_],
                                       bool]:
        """Bounds (a_lo, a_hi) on the joint acceleration qdd, which side is set by a position limit, and whether
        the bounds had to be reconciled.

        Three conditions on the same qdd, the tightest kept:
        - velocity limit, on the horizon: |qd + T qdd| <= v_max (exponential approach, time constant T);
        - braking curve, on the next sample: qd + dt qdd within the braking velocities (``braking_velocity``), so
          the joint can always still stop before its position limit (past a limit: return, on the horizon);
        - range, on the next sample: q + dt (qd + dt qdd) within the position limits.
        They can contradict each other (a joint too fast, too close to its limit): then the position side is
        kept and the other side gives way (reported as relaxed).
        """
        a_lo, a_hi, low_from_position, high_from_position, reconciled = self._bounds_values(q.tolist(), qd.tolist())
        return (np.array(a_lo), np.array(a_hi), np.array(low_from_position), np.array(high_from_position),
                reconciled)

    def _bounds_values(self, q: list[float], qd: list[float]
                       ) -> tuple[list[float], list[float], list[bool], list[bool], bool]:
        """``acceleration_bounds`` on floats, per joint (7 joints: cheaper than ~30 numpy calls on 7-vectors)."""
        dt = self.control_period
        horizon = self._horizon
        lag = self._braking_lag
        a_lo, a_hi, low_from_position, high_from_position = [], [], [], []
        reconciled = False
        for position, velocity, velocity_limit, lower, upper, deceleration, free_low, free_high in zip(
                q, qd, self._velocity_values, self._lower_values, self._upper_values, self._deceleration_values,
                self._free_low_values, self._free_high_values):
            if free_low < position < free_high and -velocity_limit <= velocity <= velocity_limit:
                # Far from both limits (``admissible``): the velocity limit sets both bounds.
                a_lo.append((-velocity_limit - velocity) / horizon)
                a_hi.append((velocity_limit - velocity) / horizon)
                low_from_position.append(False)
                high_from_position.append(False)
                continue
            low, high, low_set_by_position, high_set_by_position, conflict = _joint_bounds(
                position, velocity, velocity_limit, lower, upper, deceleration, dt, horizon, lag)
            reconciled = reconciled or conflict
            a_lo.append(low)
            a_hi.append(high)
            low_from_position.append(low_set_by_position)
            high_from_position.append(high_set_by_position)
        return a_lo, a_hi, low_from_position, high_from_position, reconciled

    def shape(self, desired_torque: NDArray[np.float64], previous_torque: NDArray[np.float64] | None,
              q: NDArray[np.float64], qd: NDArray[np.float64], bias: NDArray[np.float64],
              mass_matrix_inverse: NDArray[np.float64], tcp_linear_jacobian: NDArray[np.float64],
              position_margin: NDArray[np.float64] | None = None) -> ShapedTorque:
        """Shape ``desired_torque`` (7,) into the limits.

        ``bias`` is what the torque works against, C qd + g + D qd, so that M qdd = tau - bias;
        ``tcp_linear_jacobian`` the 3x7 linear rows of the TCP Jacobian (base frame); ``position_margin`` the
        distance of each joint to its nearest position limit, if the caller has it. Inputs are trusted (the
        replica validated them).
        """
        limits = self.limits
        horizon = self._horizon
        # Joint velocity extrapolated T ahead under tau_d, and the TCP velocity it gives.
        acceleration = mass_matrix_inverse.dot(desired_torque - bias)
        ahead = qd + horizon * acceleration
        tcp_ahead = tcp_linear_jacobian.dot(ahead)
        tcp_ahead_squared = float(tcp_ahead @ tcp_ahead)

        # Fast path: far from every position limit and nothing else broken -> the command is tau_d, unshaped.
        if position_margin is None:
            position_margin = np.minimum(q - limits.lower_array, limits.upper_array - q)
        # (With |qd| and |ahead| <= v_max and the room beyond v_max^2 / 2a and v_max dt, neither the braking nor
        # the next-sample position bound can bind.)
        desired_values = desired_torque.tolist()
        previous_values = None if previous_torque is None else previous_torque.tolist()
        qd_values = qd.tolist()
        if self._admits_unshaped(desired_values, previous_values, qd_values, ahead.tolist(), tcp_ahead_squared,
                                 position_margin.tolist()):
            return ShapedTorque(desired_torque, LimitFlag.NONE, 0.0, False, False, False, 0, True)
        # Near a position limit but nothing broken: the same answer as the flags below, on floats.
        q_values = q.tolist()
        if self._satisfies_every_limit(desired_values, previous_values, q_values, qd_values,
                                       acceleration.tolist(), tcp_ahead_squared):
            return ShapedTorque(desired_torque, LimitFlag.NONE, 0.0, False, False, False, 0)
        torque, flags, change, solved_qp, relaxed, guard, iterations = self._shape_values(
            desired_torque, desired_values, previous_values, q_values, qd, qd_values, bias, mass_matrix_inverse,
            tcp_linear_jacobian, tcp_ahead.tolist(), tcp_ahead_squared)
        return ShapedTorque(torque, LIMIT_FLAGS[flags], change, solved_qp, relaxed, guard, iterations)

    def shape_rejected(self, desired_torque: NDArray[np.float64], desired_values: list[float],
                       previous_values: list[float] | None, q_values: list[float], qd: NDArray[np.float64],
                       qd_values: list[float], bias: NDArray[np.float64], mass_matrix_inverse: NDArray[np.float64],
                       tcp_linear_jacobian: NDArray[np.float64]
                       ) -> tuple[NDArray[np.float64], int, float, bool, bool, bool]:
        """``shape`` for a tau_d that its fast-path tests already rejected (the replica's ``admissible`` verdict):
        the TCP velocity T ahead as ``shape`` computes it, then ``_shape_values``, without a ShapedTorque.

        Returns (torque, flags as an int (LIMIT_FLAGS[flags] is the LimitFlag), |torque - tau_d|, solved_qp,
        relaxed, guard_clipped). ``bias`` is C qd + g + D qd; the lists are the arrays' values as Python floats.
        """
        ahead = qd + self._horizon * mass_matrix_inverse.dot(desired_torque - bias)
        tcp_ahead = tcp_linear_jacobian.dot(ahead)
        return self._shape_values(desired_torque, desired_values, previous_values, q_values, qd, qd_values, bias,
                                  mass_matrix_inverse, tcp_linear_jacobian, tcp_ahead.tolist(),
                                  float(tcp_ahead @ tcp_ahead))[:6]

    def _shape_values(self, desired_torque: NDArray[np.float64], desired_values: list[float],
                      previous_values: list[float] | None, q_values: list[float], qd: NDArray[np.float64],
                      qd_values: list[float], bias: NDArray[np.float64], mass_matrix_inverse: NDArray[np.float64],
                      tcp_linear_jacobian: NDArray[np.float64], tcp_ahead: list[float], tcp_ahead_squared: float
                      ) -> tuple[NDArray[np.float64], int, float, bool, bool, bool, int]:
        """``shape`` after its fast-path tests, for a tau_d that they did not admit: the flags of what tau_d
        breaks, then the QP and the last guard. ``tcp_ahead`` is the TCP velocity T ahead under tau_d.

        Returns (torque, flags as an int, |torque - tau_d|, solved_qp, relaxed, guard_clipped, iterations); the
        torque is ``desired_torque`` itself if tau_d breaks nothing after all. The per-joint logic runs on floats
        (the same comparisons as torque_box, acceleration_bounds and the flag tests on numpy 7-vectors).
        """
        limits = self.limits
        horizon = self._horizon
        step = self.rate_step
        minv_tau_d = mass_matrix_inverse.dot(desired_torque)
        free_acceleration = mass_matrix_inverse.dot(bias)                  # M^-1 bias: qdd = M^-1 tau - this
        a_lo, a_hi, position_low, position_high, reconciled = self._bounds_values(q_values, qd_values)
        tcp_max = limits.tcp_speed

        # The hard box (torque_box) and the flags of the torque and torque-rate limits that tau_d breaks.
        flags = _NONE
        if previous_values is None:
            lower, upper = self._negative_torque_values, self._torque_values
            for desired, torque_max in zip(desired_values, self._torque_values):
                if abs(desired) > torque_max:  # (the box is the torque limits)
                    flags = _TORQUE
        else:
            lower, upper = [], []
            outside_box = False
            for desired, previous, torque_max in zip(desired_values, previous_values, self._torque_values):
                # Torque limits intersected with the rate step; if the last command was beyond a torque limit by
                # more than a step, the torque limit wins (the box is the clipped last command).
                box_low = previous - step
                if box_low < -torque_max:
                    box_low = -torque_max
                box_high = previous + step
                if box_high > torque_max:
                    box_high = torque_max
                if box_low > box_high:
                    box_low = box_high = -torque_max if previous < -torque_max else \
                        (torque_max if previous > torque_max else previous)
                lower.append(box_low)
                upper.append(box_high)
                if abs(desired - previous) > step:
                    flags |= _TORQUE_RATE
                if abs(desired) > torque_max:
                    flags |= _TORQUE
                if desired > box_high or desired < box_low:
                    outside_box = True
            if outside_box and not flags:  # box emptied by an out-of-limit tau_prev
                flags = _TORQUE
        # The bounds on the predicted acceleration, written on M^-1 tau = qdd + M^-1 bias, and the flags of the
        # joint limits that tau_d breaks (a_lo <= a_hi, so at most one side per joint).
        free_values = free_acceleration.tolist()
        row_lower = [low + free for low, free in zip(a_lo, free_values)]
        row_upper = [high + free for high, free in zip(a_hi, free_values)]
        for minv_desired, low, high, low_by_position, high_by_position in zip(
                minv_tau_d.tolist(), row_lower, row_upper, position_low, position_high):
            if minv_desired > high:
                flags |= _JOINT_POSITION if high_by_position else _JOINT_VELOCITY
            elif minv_desired < low:
                flags |= _JOINT_POSITION if low_by_position else _JOINT_VELOCITY
        tcp_ahead_speed = math.sqrt(tcp_ahead_squared)
        if tcp_ahead_speed > tcp_max:
            flags |= _TCP_SPEED
        if flags == _NONE:
            return desired_torque, _NONE, 0.0, False, False, False, 0

        # The QP, in daqp's form: 1/2 x'Hx + f'x, lower <= x <= upper (simple bounds), row bounds on A x.
        self.qp_count += 1
        hessian = mass_matrix_inverse
        linear = -minv_tau_d
        tcp_velocity = tcp_linear_jacobian.dot(qd)
        bounds_upper = upper + row_upper
        bounds_lower = lower + row_lower
        cut_rows: list[NDArray[np.float64]] = []
        cut_upper: list[float] = []
        if tcp_ahead_speed > tcp_max:
            self._add_cut(np.array(tcp_ahead) / tcp_ahead_speed, tcp_linear_jacobian, mass_matrix_inverse,
                          tcp_velocity, free_acceleration, horizon, cut_rows, cut_upper)
        softened = False
        iterations = 0
        torque = None
        multipliers = None
        for _ in range(self.tcp_cuts + 1):
            if cut_rows:
                rows = np.vstack([mass_matrix_inverse, *cut_rows])
                b_upper = np.array(bounds_upper + cut_upper)
                b_lower = np.array(bounds_lower + [-_INFINITY] * len(cut_rows))
            else:
                rows, b_upper, b_lower = mass_matrix_inverse, np.array(bounds_upper), np.array(bounds_lower)
            solution, n_iter, lam, soft = self._solve(hessian, linear, rows, b_upper, b_lower, softened)
            iterations += n_iter
            if solution is None:
                break
            softened = softened or soft
            torque, multipliers = solution, lam
            # The TCP velocity T ahead under the solution.
            ahead = tcp_velocity + horizon * tcp_linear_jacobian.dot(mass_matrix_inverse.dot(torque)
                                                                      - free_acceleration)
            speed = math.sqrt(ahead @ ahead)
            if speed <= tcp_max * (1.0 + _TCP_RELATIVE_TOLERANCE) or len(cut_rows) >= self.tcp_cuts:
                break
            self._add_cut(ahead / speed, tcp_linear_jacobian, mass_matrix_inverse, tcp_velocity, free_acceleration,
                          horizon, cut_rows, cut_upper)

        if torque is None:  # the solver failed: the last guard alone
            torque_values = desired_values
        else:
            torque_values = torque.tolist()
            # The active set is what shaped the command: tau - tau_d = -H^-1 (sum of active multipliers * rows).
            # (A constraint that tau_d broke but that is slack at the solution did not shape it.)
            active = self._active_flags(multipliers, torque_values, previous_values, position_low, position_high,
                                        len(cut_rows))
            flags = active if active else flags
        relaxed = reconciled or softened
        if relaxed:
            self.relaxed_count += 1

        # Last guard: never outside the torque and torque-rate box.
        clipped = [low if value < low else (high if value > high else value)  # (lower <= upper)
                   for value, low, high in zip(torque_values, lower, upper)]
        clips = [abs(value - before) > _GUARD_TOLERANCE for value, before in zip(clipped, torque_values)]
        guard = True in clips
        if guard:
            self.guard_clips += 1
            flags |= self._box_flags(clipped, previous_values, clips) or _TORQUE
        torque = np.array(clipped)
        change = torque - desired_torque
        return torque, flags, math.sqrt(change @ change), True, relaxed, guard, iterations

    def _admits_unshaped(self, desired_torque: list[float], previous_torque: list[float] | None,
                         qd: list[float], ahead: list[float], tcp_ahead_squared: float,
                         position_margin: list[float]) -> bool:
        """The fast path's test, on floats: tau_d inside the torque and torque-rate box, |qd| and the velocity
        extrapolated T ahead (``ahead``) within the velocity limits, the TCP speed T ahead within its limit, and
        every joint farther from its position limits than the braking bound can reach (``_free_room``)."""
        if tcp_ahead_squared > self._tcp_speed_squared:
            return False
        for torque, torque_limit, velocity, velocity_ahead, velocity_limit, margin, room in zip(
                desired_torque, self._torque_values, qd, ahead, self._velocity_values, position_margin,
                self._free_room_values):
            if not (abs(torque) <= torque_limit and abs(velocity_ahead) <= velocity_limit
                    and abs(velocity) <= velocity_limit and margin > room):
                return False
        if previous_torque is not None:
            step = self.rate_step
            for torque, previous in zip(desired_torque, previous_torque):
                if not abs(torque - previous) <= step:
                    return False
        return True

    def _satisfies_every_limit(self, desired_torque: list[float], previous_torque: list[float] | None,
                               q: list[float], qd: list[float], acceleration: list[float],
                               tcp_ahead_squared: float) -> bool:
        """Whether tau_d breaks none of the constraints of the QP, on floats (the joints near a position limit,
        where ``_admits_unshaped`` cannot decide; the numpy path computes the flags when this says no).

        ``acceleration`` is the predicted qdd = M^-1 (tau_d - bias), bounded as in ``acceleration_bounds``
        (velocity on the horizon, braking curve and range on the next sample, the tightest kept); conflicting
        bounds answer no (the numpy path reports them as relaxed).
        """
        if tcp_ahead_squared > self._tcp_speed_squared:
            return False
        return self._bounded(desired_torque, desired_torque if previous_torque is None else previous_torque, q, qd,
                             acceleration, None) != VERDICT_REJECTED

    def admissible(self, desired_torque: list[float], previous_torque: list[float] | None, q: list[float],
                   qd: list[float], acceleration: list[float], tcp_ahead_squared: float,
                   position_margin: list[float]) -> int:
        """Whether tau_d passes unshaped, on floats: ``_admits_unshaped`` or ``_satisfies_every_limit``.

        Returns VERDICT_REJECTED (0) if neither holds, else VERDICT_INSIDE if moreover every joint has
        |qd| <= v_max and a margin >= 0 in ``position_margin`` (the distance of each joint to its nearest position
        limit: the measured state is inside its limits; the first test implies it), else VERDICT_UNSHAPED.
        ``acceleration`` is the predicted qdd = M^-1 (tau_d - bias). The two tests are tried in the order that
        is likely to decide with one of them: the first while the joints are far from their position limits,
        the second after a call that found a joint near one. (Both are exact; only the cost depends on it.)
        """
        if tcp_ahead_squared > self._tcp_speed_squared:
            return VERDICT_REJECTED
        if previous_torque is None:
            previous_torque = desired_torque  # no torque-rate bound: |tau_d - tau_d| = 0 <= step
        if self._far_from_limits:
            if self._fast(desired_torque, previous_torque, qd, acceleration, position_margin):
                return VERDICT_INSIDE
            return self._bounded(desired_torque, previous_torque, q, qd, acceleration, position_margin)
        verdict = self._bounded(desired_torque, previous_torque, q, qd, acceleration, position_margin)
        if verdict or not self._fast(desired_torque, previous_torque, qd, acceleration, position_margin):
            return verdict
        return VERDICT_INSIDE

    def _fast(self, desired_torque: list[float], previous_torque: list[float], qd: list[float],
              acceleration: list[float], position_margin: list[float]) -> bool:
        """``_admits_unshaped`` but for the TCP speed, with the velocity T ahead from ``acceleration``."""
        horizon = self._horizon
        step = self.rate_step
        for torque, previous, torque_limit, velocity, qdd, velocity_limit, margin, room in zip(
                desired_torque, previous_torque, self._torque_values, qd, acceleration, self._velocity_values,
                position_margin, self._free_room_values):
            if not (abs(torque) <= torque_limit and abs(torque - previous) <= step and margin > room
                    and abs(velocity) <= velocity_limit and abs(velocity + horizon * qdd) <= velocity_limit):
                return False
        return True

    def _bounded(self, desired_torque: list[float], previous_torque: list[float], q: list[float], qd: list[float],
                 acceleration: list[float], position_margin: list[float] | None) -> int:
        """``_satisfies_every_limit`` but for the TCP speed: VERDICT_REJECTED, or VERDICT_INSIDE / VERDICT_UNSHAPED
        as in ``admissible`` (VERDICT_UNSHAPED without ``position_margin``). Records whether every joint was far
        from its position limits (``_far_from_limits``).

        A joint with |qd| <= v_max and farther than ``_free_room`` (plus _FREE_ROOM_GUARD) from both position
        limits has its acceleration bounds set by the velocity limit alone (the braking and next-sample bounds are
        looser, by more than their rounding: the comparisons of ``_joint_bounds`` pick the velocity bounds), so
        only those are computed for it.
        """
        horizon = self._horizon
        step = self.rate_step
        dt = self.control_period
        lag = self._braking_lag
        inside = position_margin is not None
        far = True
        for torque, previous, torque_limit, position, velocity, qdd, velocity_limit, margin, free_low, free_high, \
                lower, upper, deceleration in zip(desired_torque, previous_torque, self._torque_values, q, qd,
                                                  acceleration, self._velocity_values,
                                                  position_margin if inside else q, self._free_low_values,
                                                  self._free_high_values, self._lower_values, self._upper_values,
                                                  self._deceleration_values):
            if not (abs(torque) <= torque_limit and abs(torque - previous) <= step):
                return VERDICT_REJECTED
            if free_low < position < free_high and -velocity_limit <= velocity <= velocity_limit:
                # Far from both limits, |qd| <= v_max: the velocity limit sets both bounds.
                if not (-velocity_limit - velocity) / horizon <= qdd <= (velocity_limit - velocity) / horizon:
                    return VERDICT_REJECTED
                if inside:
                    inside = margin >= 0.0
            else:
                far = False
                low, high, _, _, reconciled = _joint_bounds(position, velocity, velocity_limit, lower, upper,
                                                            deceleration, dt, horizon, lag)
                if reconciled or not low <= qdd <= high:
                    return VERDICT_REJECTED
                if inside:
                    inside = abs(velocity) <= velocity_limit and margin >= 0.0
        self._far_from_limits = far
        return VERDICT_INSIDE if inside else VERDICT_UNSHAPED

    def _solve(self, hessian, linear, rows, b_upper, b_lower, relaxed: bool):
        """Solve with hard prediction constraints; on infeasibility, again with them soft (bounds stay hard)."""
        size = b_upper.size
        x, _, exitflag, info = daqp.solve(hessian, linear, rows, b_upper, b_lower, self._sense(size, relaxed),
                                          iter_limit=self.iteration_limit)
        iterations = info["iterations"]
        if exitflag == _EXIT_INFEASIBLE and not relaxed:
            x, _, exitflag, info = daqp.solve(hessian, linear, rows, b_upper, b_lower, self._sense(size, True),
                                              iter_limit=self.iteration_limit)
            iterations += info["iterations"]
            relaxed = True
        if exitflag < 0 or not math.isfinite(sum(x.tolist())) and not np.all(np.isfinite(x)):
            return None, int(iterations), None, relaxed
        return np.array(x), int(iterations), info["lam"].tolist(), relaxed

    def _sense(self, size: int, relaxed: bool) -> NDArray[np.int32]:
        """daqp's sense array: the 7 simple bounds hard, the rows soft if relaxed (a copy of a cached one: daqp
        keeps its working set in the array it is given)."""
        sense = self._senses.get((size, relaxed))
        if sense is None:
            sense = np.full(size, _SENSE_SOFT if relaxed else _SENSE_INEQUALITY, dtype=np.int32)
            sense[:7] = _SENSE_INEQUALITY
            self._senses[(size, relaxed)] = sense
        return sense.copy()

    def _add_cut(self, direction, tcp_linear_jacobian, mass_matrix_inverse, tcp_velocity, free_acceleration,
                 horizon, cut_rows, cut_upper) -> None:
        # u^T J_v (qd + T (M^-1 tau - M^-1 bias)) <= v_max   <=>   (u^T J_v M^-1) tau <= (v_max - u^T v)/T + u^T J_v
        # M^-1 bias
        projected = direction @ tcp_linear_jacobian
        cut_rows.append(projected @ mass_matrix_inverse)
        cut_upper.append(float((self.limits.tcp_speed * (1.0 - _TCP_CUT_SHRINK) - direction @ tcp_velocity) / horizon
                               + projected @ free_acceleration))

    def _box_flags(self, torque: list[float], previous_torque: list[float] | None, mask: list[bool]) -> int:
        """Which of the torque and torque-rate limits the (masked) joints of a torque on the box's boundary sit on."""
        flags = _NONE
        for selected, value, edge in zip(mask, torque, self._torque_edge_values):
            if selected and abs(value) >= edge:
                flags |= _TORQUE
                break
        if previous_torque is not None:
            edge = self._rate_edge
            for selected, value, previous in zip(mask, torque, previous_torque):
                if selected and abs(value - previous) >= edge:
                    flags |= _TORQUE_RATE
                    break
        return flags

    def _active_flags(self, multipliers: list[float], torque: list[float], previous_torque: list[float] | None,
                      position_low: list[bool], position_high: list[bool], n_cuts: int) -> int:
        """The limits whose constraints are active (non-zero multiplier) at the solution: the simple bounds (7),
        the joint rows (7; a positive multiplier is the upper side) and the TCP cuts."""
        active = [abs(value) > _MULTIPLIER_TOLERANCE for value in multipliers]
        flags = _NONE
        if True in active[:7]:
            flags |= self._box_flags(torque, previous_torque, active[:7])
        for selected, multiplier, low_by_position, high_by_position in zip(
                active[7:14], multipliers[7:14], position_low, position_high):
            if selected:
                if multiplier > 0.0:
                    flags |= _JOINT_POSITION if high_by_position else _JOINT_VELOCITY
                else:
                    flags |= _JOINT_POSITION if low_by_position else _JOINT_VELOCITY
        if n_cuts and True in active[14:14 + n_cuts]:
            flags |= _TCP_SPEED
        return flags




def _joint_bounds(position: float, velocity: float, velocity_limit: float, lower: float, upper: float,
                  deceleration: float, dt: float, horizon: float, lag: float
                  ) -> tuple[float, float, bool, bool, bool]:
    """One joint of ``acceleration_bounds`` on floats: (a_lo, a_hi, a_lo set by the position limit, a_hi set by
    it, the bounds had to be reconciled)."""
    velocity_high = (velocity_limit - velocity) / horizon
    velocity_low = (-velocity_limit - velocity) / horizon
    room_high = upper - position
    room_low = position - lower
    # Inside: the braking curve (braking_velocity) and the range on the next sample; beyond: the return
    # speed on the horizon.
    if room_high >= 0.0:
        brake_high = deceleration * (math.sqrt(lag * lag + 2.0 * room_high / deceleration) - lag)
        position_high = min((brake_high - velocity) / dt, (room_high / dt - velocity) / dt)
    else:
        position_high = (room_high / horizon - velocity) / horizon
    if room_low >= 0.0:
        brake_low = -(deceleration * (math.sqrt(lag * lag + 2.0 * room_low / deceleration) - lag))
        position_low = max((brake_low - velocity) / dt, (-room_low / dt - velocity) / dt)
    else:
        position_low = (-(room_low / horizon) - velocity) / horizon
    high_set_by_position = position_high < velocity_high
    low_set_by_position = position_low > velocity_low
    high = position_high if high_set_by_position else velocity_high
    low = position_low if low_set_by_position else velocity_low
    reconciled = False
    if low > high:  # conflict: the position side is kept, the other gives way
        reconciled = True
        if high_set_by_position:
            low = high  # stop short of the upper limit
        else:
            high = low  # stop short of the lower limit
    return low, high, low_set_by_position, high_set_by_position, reconciled
