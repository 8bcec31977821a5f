"""The limits as properties, each against a recomputation of the test's own (docs/CONTROL_LAWS.md, "The limits"):

- the violation check (``limit_violations``, and the replica's fused checks on its tick) flags exactly what a
  per-joint recomputation flags, at the limits and within a few slacks of them on either side (a value on a limit,
  or beyond it by at most the documented slack of 1e-9, is inside);
- the postural optimisation's fast paths (``admissible``, the replica's, and ``shape``'s own) pass tau_d unshaped
  exactly when tau_d meets every constraint of the QP written out here (torque, torque rate, joint velocity on
  the horizon, braking curve and range on the next sample, TCP speed), on random states, limits and demands with
  one joint placed just inside or just outside one constraint;
- what leaves the optimisation never breaks a torque or torque-rate limit, nor (when its QP was feasible) a joint
  velocity or position limit on the next sample, as ``limit_violations`` recomputes them.
"""
from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from fic_core.limits import LimitFlag, PandaLimits, limit_violations
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.postural_optimisation import (
    BRAKING_TORQUE_RAMP,
    DEFAULT_BRAKING_DECELERATION,
    VERDICT_INSIDE,
    VERDICT_REJECTED,
    VERDICT_UNSHAPED,
    PosturalOptimisation,
)
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel

#: The violation check's documented slack: a value beyond its limit by at most this much is inside [SI units].
SLACK = 1e-9
#: Where a value sits, in slacks beyond its limit: well inside, half a slack inside, on it, within the slack, past.
OFFSETS = (-2.0, -0.5, 0.0, 0.5, 2.0)
VELOCITY_HORIZON = 0.05   # [s] the optimisation's default T


def recomputed_violations(previous, torque, q, qd, tcp_speed: float, dt: float, limits: PandaLimits) -> LimitFlag:
    """The violation flags joint by joint: a limit is broken when the value is past it by more than SLACK."""
    flags = LimitFlag.NONE
    for joint in range(7):
        if abs(torque[joint]) - limits.torque[joint] > SLACK:
            flags |= LimitFlag.TORQUE
        if previous is not None and abs(torque[joint] - previous[joint]) - limits.torque_rate * dt > SLACK:
            flags |= LimitFlag.TORQUE_RATE
        if abs(qd[joint]) - limits.joint_velocity[joint] > SLACK:
            flags |= LimitFlag.JOINT_VELOCITY
        if limits.joint_position_lower[joint] - q[joint] > SLACK \
                or q[joint] - limits.joint_position_upper[joint] > SLACK:
            flags |= LimitFlag.JOINT_POSITION
    if tcp_speed - limits.tcp_speed > SLACK:
        flags |= LimitFlag.TCP_SPEED
    return flags


def _near(limit: float, offset: float, sign: float) -> float:
    """``sign`` x (|limit| + offset slacks): on the limit's side ``sign``, ``offset`` slacks past it."""
    return sign * (limit + offset * SLACK)


@settings(max_examples=100, deadline=None, derandomize=True)
@given(data=st.data(), dt=st.sampled_from([0.001, 0.002, 0.004]), first=st.booleans())
def test_the_violation_check_agrees_with_a_recomputation_at_and_around_the_limits(data, dt: float, first: bool,
                                                                                  limits: PandaLimits) -> None:
    inside = st.floats(-0.9, 0.9)
    offset = st.sampled_from(OFFSETS)
    sign = st.sampled_from([-1.0, 1.0])
    at_limit = st.booleans()
    torque, previous, qd, q = [], [], [], []
    for joint in range(7):
        # The torque on or about its limit, or the rate step from the previous command on or about its limit.
        value = _near(limits.torque[joint], data.draw(offset), data.draw(sign)) if data.draw(at_limit) else \
            data.draw(inside) * limits.torque[joint]
        torque.append(value)
        step = limits.torque_rate * dt
        previous.append(value - _near(step, data.draw(offset), data.draw(sign)) if data.draw(at_limit) else
                        value - data.draw(inside) * step)
        qd.append(_near(limits.joint_velocity[joint], data.draw(offset), data.draw(sign)) if data.draw(at_limit)
                  else data.draw(inside) * limits.joint_velocity[joint])
        lower, upper = limits.joint_position_lower[joint], limits.joint_position_upper[joint]
        if data.draw(at_limit):
            below = data.draw(st.booleans())
            q.append(lower - data.draw(offset) * SLACK if below else upper + data.draw(offset) * SLACK)
        else:
            q.append(lower + (upper - lower) * (0.5 + 0.45 * data.draw(inside)))
    tcp_speed = limits.tcp_speed + data.draw(offset) * SLACK if data.draw(at_limit) else \
        limits.tcp_speed * (0.5 + 0.5 * data.draw(inside))
    previous = None if first else previous
    assert limit_violations(previous, torque, q, qd, tcp_speed, dt, limits) == \
        recomputed_violations(previous, torque, q, qd, tcp_speed, dt, limits)


def test_each_limit_is_inside_on_it_and_within_the_slack_and_broken_past_it(limits: PandaLimits) -> None:
    """The slack's two sides for each limit alone: on it and half a slack past it are inside, two slacks past it
    are broken (the sign of the slack in each comparison)."""
    dt = 0.001
    q = np.array(NOMINAL_CONFIGURATION)
    rest = np.zeros(7)
    cases = {LimitFlag.TORQUE: lambda past: (None, rest + np.eye(7)[4] * (12.0 + past), q, rest, 0.0),
             LimitFlag.TORQUE_RATE: lambda past: (rest, rest + np.eye(7)[1] * (1.0 + past), q, rest, 0.0),
             LimitFlag.JOINT_VELOCITY: lambda past: (None, rest, q, rest - np.eye(7)[6] * (2.61 + past), 0.0),
             LimitFlag.TCP_SPEED: lambda past: (None, rest, q, rest, 1.7 + past)}
    for joint, side in ((0, "lower"), (3, "upper")):
        def moved(past, joint=joint, side=side):
            position = q.copy()
            position[joint] = limits.joint_position_lower[joint] - past if side == "lower" else \
                limits.joint_position_upper[joint] + past
            return None, rest, position, rest, 0.0
        cases[LimitFlag.JOINT_POSITION, joint] = moved
    for flag, state in cases.items():
        expected = flag[0] if isinstance(flag, tuple) else flag
        for past, broken in ((0.0, False), (0.5 * SLACK, False), (2.0 * SLACK, True)):
            previous, torque, position, velocity, tcp_speed = state(past)
            assert limit_violations(previous, torque, position, velocity, tcp_speed, dt, limits) == \
                (expected if broken else LimitFlag.NONE), (flag, past)


def test_exactly_the_slack_past_a_limit_is_inside() -> None:
    """Limits of 1e-9 (and a rate step of 1e-9), where the arithmetic is exact: 2e-9 is exactly one slack past each,
    and inside; the next float above it is past the slack."""
    lower, upper = (0.0,) * 7, (1.0,) * 7
    tiny = PandaLimits(lower, upper, torque=(SLACK,) * 7, torque_rate=1.0, joint_velocity=(SLACK,) * 7,
                       tcp_speed=SLACK)
    dt = SLACK   # rate x dt = 1e-9
    rest, middle = [0.0] * 7, [0.5] * 7
    on_slack, past = 2.0 * SLACK, np.nextafter(2.0 * SLACK, 1.0)
    assert on_slack - SLACK == SLACK and 0.0 - SLACK == -SLACK
    for value, expected in ((on_slack, LimitFlag.NONE), (past, None)):
        one = [value] + rest[1:]
        flags = {LimitFlag.TORQUE: limit_violations(None, one, middle, rest, 0.0, dt, tiny),
                 LimitFlag.TORQUE_RATE: limit_violations(rest, one, middle, rest, 0.0, dt, tiny)
                 & LimitFlag.TORQUE_RATE,
                 LimitFlag.JOINT_VELOCITY: limit_violations(None, rest, middle, one, 0.0, dt, tiny),
                 LimitFlag.TCP_SPEED: limit_violations(None, rest, middle, rest, value, dt, tiny)}
        for flag, found in flags.items():
            assert found == (expected if expected is not None else flag), (flag, value)
    # Positions: exactly one slack below the lower limit of 0 and above the upper of 1 (1 + 1e-9 rounds to within
    # 1e-16 of it: the upper side is checked a hair inside and past instead).
    below = [-SLACK] + middle[1:]
    assert limit_violations(None, rest, below, rest, 0.0, dt, tiny) == LimitFlag.NONE
    below[0] = np.nextafter(-SLACK, -1.0)
    assert limit_violations(None, rest, below, rest, 0.0, dt, tiny) == LimitFlag.JOINT_POSITION


def _replica(robot: RobotModel) -> ReplicaController:
    return ReplicaController(robot, PoseAttractor(ForceProfile(2000.0, 0.05, 0.5, 200.0),
                                                  ForceProfile(100.0, 0.5, 0.5, 30.0)))


def test_the_replicas_violation_flags_agree_with_the_recomputation_at_and_around_the_limits(
        robot: RobotModel, limits: PandaLimits) -> None:
    """Ticks of the replica with joints placed on their position or velocity limits and a few slacks either side,
    stiff demands that drive the torque onto its box: the tick's limit_violations are what limits.py and the
    recomputation give for the torque sent, the one sent before it, the state and the TCP speed."""
    rng = np.random.default_rng(44)
    replica = _replica(robot)
    target = robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    position, rotation = target.tcp_position.copy(), target.tcp_rotation.copy()
    lower, upper, v_max = limits.lower_array, limits.upper_array, limits.joint_velocity_array
    seen = LimitFlag.NONE
    clear = 0
    for tick in range(240):
        if tick % 8 == 0:
            replica.reset(previous_torque=rng.uniform(-1.0, 1.0, 7) * limits.torque_array)
        q = rng.uniform(lower + 0.3, upper - 0.3)
        qd = rng.uniform(-0.3, 0.3, 7) * v_max
        for joint in rng.choice(7, size=rng.integers(0, 3), replace=False):
            past = rng.choice(OFFSETS) * SLACK
            if rng.random() < 0.5:
                q[joint] = lower[joint] - past if rng.random() < 0.5 else upper[joint] + past
            else:
                qd[joint] = rng.choice([-1.0, 1.0]) * (v_max[joint] + past)
        previous = replica.previous_torque
        command = replica.command(q, qd, position + rng.normal(scale=0.3, size=3), rotation)
        expected = limit_violations(previous, command.torque, q, qd, command.tcp_speed, replica.control_period,
                                    limits)
        assert command.limit_violations == expected, tick
        assert expected == recomputed_violations(previous, command.torque, q, qd, command.tcp_speed,
                                                 replica.control_period, limits), tick
        seen |= expected
        clear += expected == LimitFlag.NONE
    assert seen & LimitFlag.JOINT_POSITION and seen & LimitFlag.JOINT_VELOCITY and clear > 40, (seen, clear)


def test_the_replica_and_limits_py_agree_on_the_float_nearest_the_limit_plus_the_slack(robot: RobotModel,
                                                                                      limits: PandaLimits) -> None:
    """A measured joint speed of fl(v_max + 1e-9), the float nearest the limit plus the slack, exceeds v_max by more
    than 1e-9 (the sum rounds up) and limits.py flags it; the replica's tick flags it too, on either side, and the
    float below it is inside for both. (The replica's fused check once compared |qd| <= v_max + 1e-9 and called it
    inside.)"""
    replica = _replica(robot)
    state = robot.update(NOMINAL_CONFIGURATION, np.zeros(7))
    position, rotation = state.tcp_position.copy(), state.tcp_rotation.copy()
    for joint in range(7):
        limit = limits.joint_velocity[joint]
        rounded = limit + SLACK
        assert rounded - limit > SLACK          # what makes this float the one to test
        for speed, broken in ((rounded, True), (float(np.nextafter(rounded, 0.0)), False)):
            for sign in (1.0, -1.0):
                qd = np.zeros(7)
                qd[joint] = sign * speed
                previous = replica.previous_torque
                command = replica.command(NOMINAL_CONFIGURATION, qd, position, rotation)
                expected = limit_violations(previous, command.torque, NOMINAL_CONFIGURATION, qd, command.tcp_speed,
                                            replica.control_period, limits)
                assert (LimitFlag.JOINT_VELOCITY in expected) == broken, (joint, speed)
                assert command.limit_violations == expected, (joint, sign, speed)


# ---------------------------------------------------------------------------------------------------------------
# The postural optimisation: its fast paths against the QP's constraints written out, and its output against the
# violation check.

def braking_speed(room: float, deceleration: float, lag: float) -> float:
    """v with v L + v^2 / (2 a) = room: the speed from which a joint stops within ``room`` braking at a after L."""
    return deceleration * (math.sqrt(lag * lag + 2.0 * room / deceleration) - lag)


def written_out_bounds(limits: PandaLimits, q, qd, dt: float, horizon: float) -> list[tuple[float, float]]:
    """(low, high) on each joint's acceleration, the tightest of: |qd + T qdd| <= v_max; the next sample's
    velocity within the braking speeds of both position limits; the next sample inside the range (a joint inside
    its limits)."""
    lag = horizon + BRAKING_TORQUE_RAMP
    bounds = []
    for joint in range(7):
        v_max = limits.joint_velocity[joint]
        deceleration = DEFAULT_BRAKING_DECELERATION[joint]
        room_high = limits.joint_position_upper[joint] - q[joint]
        room_low = q[joint] - limits.joint_position_lower[joint]
        high = min((v_max - qd[joint]) / horizon, (braking_speed(room_high, deceleration, lag) - qd[joint]) / dt,
                   (room_high / dt - qd[joint]) / dt)
        low = max((-v_max - qd[joint]) / horizon, (-braking_speed(room_low, deceleration, lag) - qd[joint]) / dt,
                  (-room_low / dt - qd[joint]) / dt)
        bounds.append((low, high))
    return bounds


def written_out_slacks(limits: PandaLimits, q, qd, desired, previous, acceleration, tcp_ahead: float, dt: float,
                       horizon: float) -> list[float]:
    """Every constraint of the QP (postural_optimisation.py's docstring) at tau_d, as slack / scale: > 0 where
    tau_d meets it (conflicting acceleration bounds give a negative slack)."""
    slacks = []
    for joint, (low, high) in enumerate(written_out_bounds(limits, q, qd, dt, horizon)):
        torque_max = limits.torque[joint]
        slacks.append((torque_max - abs(desired[joint])) / torque_max)
        if previous is not None:
            step = limits.torque_rate * dt
            slacks.append((step - abs(desired[joint] - previous[joint])) / step)
        scale = 1.0 + abs(high) + abs(low)
        slacks += [(high - low) / scale, (high - acceleration[joint]) / scale, (acceleration[joint] - low) / scale]
    slacks.append((limits.tcp_speed - tcp_ahead) / limits.tcp_speed)
    return slacks


def _place(rng, limits: PandaLimits, robot: RobotModel, dt: float):
    """A random state inside the limits and a demand with every joint well inside every constraint but one joint
    placed just inside or just outside one of them (or its TCP speed), with the limits drawn around the demand."""
    lower, upper = limits.lower_array, limits.upper_array
    v_max = limits.joint_velocity_array
    lag = VELOCITY_HORIZON + BRAKING_TORQUE_RAMP
    joint = int(rng.integers(7))
    kind = rng.choice(["torque", "rate", "velocity", "position", "tcp", "speeding", "none"])
    across = rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-6, -1.5)   # < 0 just inside, > 0 just outside
    q = rng.uniform(lower + 0.4, upper - 0.4)
    qd = rng.uniform(-0.6, 0.6, 7) * v_max
    if kind == "position":   # near a position limit, moving toward it: the braking curve binds
        toward = rng.choice([-1.0, 1.0])
        room = rng.uniform(1e-4, 0.6)
        q[joint] = upper[joint] - room if toward > 0 else lower[joint] + room
        deceleration = DEFAULT_BRAKING_DECELERATION[joint]
        qd[joint] = toward * min(braking_speed(room, deceleration, lag) * rng.uniform(0.5, 1.0), v_max[joint])
    elif kind == "speeding":   # a joint already a little over its velocity limit, far from its position limits
        qd[joint] = rng.choice([-1.0, 1.0]) * v_max[joint] * (1.0 + abs(across))
    state = robot.update(q, qd)
    minv = state.mass_matrix_inverse.copy()
    mass = robot.mass_matrix.copy()
    bias = state.nonlinear_effects + robot.joint_damping * qd
    jacobian = state.tcp_jacobian[:3].copy()
    # A target acceleration well inside the written-out bounds on every joint, but one.
    bounds = written_out_bounds(limits, q, qd, dt, VELOCITY_HORIZON)
    acceleration = np.array([low + (high - low) * rng.uniform(0.3, 0.7) for low, high in bounds])
    if kind in ("velocity", "position", "speeding"):
        low, high = bounds[joint]
        acceleration[joint] = high + across * (high - low) if rng.random() < 0.5 else low - across * (high - low)
    desired = bias + mass @ acceleration
    # The limits around the demand: torque limits well above |tau_d| but one, the rate step well above the change
    # but one, the TCP speed well above the predicted one but (maybe) this joint's.
    torque_limits = np.abs(desired) * rng.uniform(1.2, 2.0, 7) + 0.5
    step = 1000.0 * dt
    previous = desired + rng.uniform(-0.6, 0.6, 7) * step
    if kind == "torque":
        torque_limits[joint] = abs(desired[joint]) / (1.0 + across)
        previous[joint] = desired[joint] - rng.uniform(-0.6, 0.6) * step   # within the step: only the torque decides
    elif kind == "rate":
        previous[joint] = desired[joint] - rng.choice([-1.0, 1.0]) * step * (1.0 + across)
    tcp_ahead = float(np.linalg.norm(jacobian @ (qd + VELOCITY_HORIZON * minv @ (desired - bias))))
    tcp_speed = tcp_ahead / (1.0 + across) if kind == "tcp" else max(2.0 * tcp_ahead, 1.7)
    drawn = PandaLimits(lower, upper, torque=tuple(torque_limits), tcp_speed=tcp_speed)
    if rng.random() < 0.2:
        previous = None   # the first command: no rate bound
    return drawn, q, qd, desired, previous, bias, minv, jacobian


def test_the_fast_paths_pass_tau_d_exactly_when_it_meets_every_written_out_constraint(
        robot: RobotModel, limits: PandaLimits) -> None:
    """``admissible`` (the replica's test) and ``shape`` pass tau_d unshaped, with no flag, exactly when it meets
    every constraint of the QP as written out above; each sample puts one joint just inside or just outside one
    constraint (torque, rate, velocity on the horizon, braking curve, TCP speed), from 1e-6 to 3 % of it, or
    over its velocity limit by as much; ``admissible`` says inside only when |qd| is within its limits too."""
    rng = np.random.default_rng(4401)
    counts = {"admitted": 0, "rejected": 0, "fast": 0, "near a limit": 0, "admitted over v_max": 0}
    for sample in range(500):
        dt = float(rng.choice([0.001, 0.004]))
        drawn, q, qd, desired, previous, bias, minv, jacobian = _place(rng, limits, robot, dt)
        acceleration = minv @ (desired - bias)
        tcp_ahead = float(np.linalg.norm(jacobian @ (qd + VELOCITY_HORIZON * acceleration)))
        slacks = written_out_slacks(drawn, q, qd, desired, previous, acceleration, tcp_ahead, dt, VELOCITY_HORIZON)
        if min(abs(slack) for slack in slacks) < 1e-9:
            continue   # on a boundary to rounding: either answer is right
        meets = min(slacks) > 0.0
        inside = bool(np.all(np.abs(qd) <= drawn.joint_velocity_array))   # and q is inside: VERDICT_INSIDE
        optimisation = PosturalOptimisation(drawn, dt, velocity_horizon=VELOCITY_HORIZON)
        margins = np.minimum(q - drawn.lower_array, drawn.upper_array - q)
        previous_values = None if previous is None else previous.tolist()
        for _ in range(2):   # twice: the second call tries the tests in the order the first call left
            verdict = optimisation.admissible(desired.tolist(), previous_values, q.tolist(), qd.tolist(),
                                              acceleration.tolist(), tcp_ahead * tcp_ahead, margins.tolist())
            assert verdict == ((VERDICT_INSIDE if inside else VERDICT_UNSHAPED) if meets else VERDICT_REJECTED), \
                (sample, slacks)
        result = optimisation.shape(desired, previous, q, qd, bias, minv, jacobian)
        assert (result.flags == LimitFlag.NONE) == meets, (sample, result.flags)
        if meets:
            np.testing.assert_array_equal(result.torque, desired)
            assert not result.solved_qp
        else:
            assert result.solved_qp and not np.array_equal(result.torque, desired)
        counts["admitted" if meets else "rejected"] += 1
        counts["fast"] += result.fast_path
        counts["near a limit"] += meets and not result.fast_path
        counts["admitted over v_max"] += meets and not inside
    assert min(counts.values()) > 10, counts


def test_a_joint_just_inside_its_free_room_is_judged_by_its_braking_curve(robot: RobotModel,
                                                                        limits: PandaLimits) -> None:
    """The fast test's "far from the limits" shortcut (velocity bounds only) must stop where the braking curve can
    bind: a joint at full speed toward its limit with 0.5 urad less room than the free room (where the braking
    speed is just below v_max) and tau_d holding that speed breaks the braking curve, and is shaped."""
    dt = 0.001
    lag = VELOCITY_HORIZON + BRAKING_TORQUE_RAMP
    for joint, toward in ((3, 1.0), (1, -1.0), (5, 1.0)):
        v_max = limits.joint_velocity[joint]
        deceleration = DEFAULT_BRAKING_DECELERATION[joint]
        free_room = max(v_max * v_max / (2.0 * deceleration) + v_max * lag, v_max * dt)
        room = free_room - 0.5e-6
        q = np.array(NOMINAL_CONFIGURATION)
        q[joint] = limits.joint_position_upper[joint] - room if toward > 0 \
            else limits.joint_position_lower[joint] + room
        qd = np.zeros(7)
        qd[joint] = toward * v_max
        state = robot.update(q, qd)
        bias = state.nonlinear_effects + robot.joint_damping * qd
        minv = state.mass_matrix_inverse.copy()
        # qdd = 0: the velocity bound (0 at |qd| = v_max) holds; the braking bound (v_b - v_max)/dt < 0 does not.
        assert (braking_speed(room, deceleration, lag) - v_max) / dt < -1e-4
        desired = bias.copy()
        optimisation = PosturalOptimisation(limits, dt, velocity_horizon=VELOCITY_HORIZON)
        margins = np.minimum(q - limits.lower_array, limits.upper_array - q)
        acceleration = minv @ (desired - bias)
        for _ in range(2):
            assert optimisation.admissible(desired.tolist(), None, q.tolist(), qd.tolist(), acceleration.tolist(),
                                           0.0, margins.tolist()) == VERDICT_REJECTED, joint
        result = optimisation.shape(desired, None, q, qd, bias, minv, state.tcp_jacobian[:3].copy())
        assert result.flags & LimitFlag.JOINT_POSITION and result.solved_qp, (joint, result.flags)
        # One micro-radian more room: the braking speed exceeds v_max and tau_d passes.
        q[joint] -= toward * 1e-6
        state = robot.update(q, qd)
        margins = np.minimum(q - limits.lower_array, limits.upper_array - q)
        assert optimisation.admissible(desired.tolist(), None, q.tolist(), qd.tolist(), acceleration.tolist(), 0.0,
                                       margins.tolist()) != VERDICT_REJECTED, joint


def test_a_demand_exactly_on_every_boundary_passes_unshaped(limits: PandaLimits) -> None:
    """On a limit is inside (docs/CONTROL_LAWS.md, "The limits"): tau_d exactly on its torque limit and exactly one
    rate step from the last command, |qd| exactly v_max with the acceleration exactly on the velocity bound, a
    joint exactly on its lower position limit at rest with qdd exactly on its braking bound (0), and the TCP
    speed T ahead exactly on its limit: ``admissible`` passes it as inside its limits, whichever of its two tests
    runs first."""
    dt = 0.001
    step = limits.torque_rate * dt
    optimisation = PosturalOptimisation(limits, dt)
    q = list(NOMINAL_CONFIGURATION)
    q[2] = limits.joint_position_lower[2]   # margin 0, at rest: the braking bound is qdd >= 0
    qd = [0.0] * 7
    qd[1], qd[5] = limits.joint_velocity[1], -limits.joint_velocity[5]   # on the velocity limits, far from q's
    desired = [0.0] * 7
    desired[4], desired[0] = limits.torque[4], -limits.torque[0]
    previous = [value - step for value in desired]
    previous[4] = desired[4] + step
    margins = [min(value - low, high - value) for value, low, high in
               zip(q, limits.joint_position_lower, limits.joint_position_upper)]
    assert margins[2] == 0.0
    tcp_squared = limits.tcp_speed * limits.tcp_speed
    acceleration = [0.0] * 7
    for first_far in (True, False):
        optimisation._far_from_limits = first_far
        assert optimisation.admissible(desired, previous, q, qd, acceleration, tcp_squared, margins) == \
            VERDICT_INSIDE, first_far
    # And each boundary a hair past: rejected.
    for joint, field, nudge in ((4, "desired", 1e-12), (0, "previous", -1e-12), (1, "acceleration", 1e-9),
                                (2, "acceleration", -1e-9), (2, "margins", None)):
        values = {"desired": list(desired), "previous": list(previous), "acceleration": list(acceleration),
                  "q": list(q)}
        if field == "margins":   # just past the lower limit: a margin below 0 makes the verdict UNSHAPED at best
            values["q"][2] -= 1e-9
            moved = [min(value - low, high - value) for value, low, high in
                     zip(values["q"], limits.joint_position_lower, limits.joint_position_upper)]
            verdict = optimisation.admissible(values["desired"], values["previous"], values["q"], qd,
                                              [0.0, 0.0, 1e-3, 0.0, 0.0, 0.0, 0.0], tcp_squared, moved)
            assert verdict in (VERDICT_REJECTED, VERDICT_UNSHAPED), verdict
            continue
        values[field][joint] += nudge
        assert optimisation.admissible(values["desired"], values["previous"], q, qd, values["acceleration"],
                                       tcp_squared, margins) == VERDICT_REJECTED, (joint, field)
    assert optimisation.admissible(desired, previous, q, qd, acceleration, tcp_squared * (1.0 + 1e-12),
                                   margins) == VERDICT_REJECTED


def test_what_leaves_the_optimisation_breaks_no_limit_as_limits_py_recomputes_it(robot: RobotModel,
                                                                               limits: PandaLimits) -> None:
    """Random states inside the limits, random previous commands and demands from gentle to huge: the command is
    inside the torque and torque-rate limits (limit_violations on it and the previous one), and when the QP was
    feasible the state it leads to one sample later (by the model) is inside the velocity and position limits."""
    rng = np.random.default_rng(4402)
    lower, upper, v_max = limits.lower_array, limits.upper_array, limits.joint_velocity_array
    feasible = 0
    for _ in range(400):
        dt = float(rng.choice([0.001, 0.004]))
        optimisation = PosturalOptimisation(limits, dt)
        near = rng.random(7) < 0.3
        edge = np.where(rng.random(7) < 0.5, lower + rng.uniform(0.0, 0.2, 7), upper - rng.uniform(0.0, 0.2, 7))
        q = np.where(near, edge, rng.uniform(lower, upper))
        qd = rng.uniform(-1.0, 1.0, 7) * v_max * rng.choice([0.2, 0.7, 1.0])
        state = robot.update(q, qd)
        bias = state.nonlinear_effects + robot.joint_damping * qd
        minv = state.mass_matrix_inverse.copy()
        jacobian = state.tcp_jacobian[:3].copy()
        previous = None if rng.random() < 0.2 else np.clip(bias + rng.normal(scale=2.0, size=7),
                                                          -limits.torque_array, limits.torque_array)
        desired = bias + rng.normal(size=7) * rng.choice([0.3, 3.0, 30.0, 300.0])
        result = optimisation.shape(desired, previous, q, qd, bias, minv, jacobian)
        flags = limit_violations(previous, result.torque, q, qd, 0.0, dt, limits)
        assert not flags & (LimitFlag.TORQUE | LimitFlag.TORQUE_RATE), flags
        if result.relaxed:
            continue
        feasible += 1
        next_velocity = qd + dt * minv @ (result.torque - bias)
        next_position = q + dt * next_velocity
        # The solver meets its rows to about 1e-9 rad/s^2 of acceleration: 1e-12 rad/s one sample on.
        assert limit_violations(previous, result.torque, next_position, next_velocity, 0.0, dt, limits) == \
            LimitFlag.NONE
    assert feasible > 150, feasible
