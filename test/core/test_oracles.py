"""Independent oracles for the replica's torque law (paper Eq. 7) and the postural optimisation.

Every expected value here is computed by the test itself: the dynamics from Pinocchio calls of its own, the FIC
force profile (paper Eq. 1 with the errata of docs/CONTROL_LAWS.md) and the attractor's laws (paper Eq. 2) written
out below, the null-space posture and the feedforward written out, and the postural optimisation's QP built from
its definition and solved by a second solver (quadprog, Goldfarb-Idnani dual active set) that the code does not
use. Nothing is read back from the command but the torque under test.
"""
from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import quadprog

from fic_core.limits import LimitFlag, PandaLimits
from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.pose_attractor import PoseAttractor
from fic_core.postural_optimisation import BRAKING_TORQUE_RAMP, DEFAULT_BRAKING_DECELERATION, PosturalOptimisation
from fic_core.profile import ForceProfile
from fic_core.replica import ReplicaController
from fic_core.robot_model import RobotModel

DT = 0.001
# The paper's replica FIC (Sec. III): K0 = 200 N/m, x_b = 0.05 m, xi = 0.5, F_max = 30 N; rotation as the code's
# configuration: 20 N m/rad, x_b = 0.5 rad, xi = 0.5, 10 N m.
TRANSLATION = (200.0, 0.05, 0.5, 30.0)
ROTATION = (20.0, 0.5, 0.5, 10.0)


def profile_force(error: float, stiffness: float, saturation_error: float, xi: float, max_force: float) -> float:
    """F_c of paper Eq. 1, written out: linear K0 e up to xi x_b, then the renormalised tanh towards F_max."""
    magnitude = abs(error)
    if magnitude <= xi * saturation_error:
        return stiffness * error
    start_force = xi * stiffness * saturation_error
    width = (1.0 - xi) * saturation_error / (2.0 * math.pi)
    low = math.tanh(-math.pi)
    shape = (math.tanh((magnitude - saturation_error) / width + math.pi) - low) / (1.0 - low)
    return math.copysign(start_force + (max_force - start_force) * shape, error)


def written_out_dynamics(robot: RobotModel, q: np.ndarray, qd: np.ndarray):
    """(C qd + G, M^-1, J (LOCAL_WORLD_ALIGNED at the TCP), Jdot qd, TCP pose) from Pinocchio calls of the test."""
    model = robot.model
    data = model.createData()
    bias = pin.rnea(model, data, q, qd, np.zeros(model.nv))
    mass = pin.crba(model, data, q)
    mass = np.triu(mass) + np.triu(mass, 1).T
    jacobian = pin.computeFrameJacobian(model, data, q, robot.tcp_frame_id, pin.LOCAL_WORLD_ALIGNED)
    pin.forwardKinematics(model, data, q, qd, np.zeros(model.nv))
    pin.updateFramePlacements(model, data)
    drift = pin.getFrameClassicalAcceleration(model, data, robot.tcp_frame_id, pin.LOCAL_WORLD_ALIGNED).vector
    placement = data.oMf[robot.tcp_frame_id]
    return bias, np.linalg.inv(mass), jacobian, drift, placement.translation.copy(), placement.rotation.copy()


def written_out_posture(replica: ReplicaController, q, qd, jacobian, minv) -> np.ndarray:
    """N^T (K (q_n - q) - D qd + repulsion), N^T = I - J^T Lambda J M^-1 (Khatib's dynamically consistent one)."""
    posture = replica.posture
    band = posture.limit_band
    low = np.maximum(band - (q - posture.lower_limit), 0.0)
    high = np.maximum(band - (posture.upper_limit - q), 0.0)
    torque = posture.stiffness * (posture.nominal - q) - posture.damping * qd \
        + posture.limit_stiffness / band * (low ** 2 - high ** 2)
    inertia = np.linalg.inv(jacobian @ minv @ jacobian.T + posture.task_regularisation * np.eye(6))
    return torque - jacobian.T @ inertia @ jacobian @ minv @ torque


def random_state(rng, scale_q: float = 0.25, scale_qd: float = 0.3):
    return NOMINAL_CONFIGURATION + rng.normal(scale=scale_q, size=7), rng.normal(scale=scale_qd, size=7)


def test_eq_7_recomputed_from_pinocchio_in_divergence(robot: RobotModel) -> None:
    """First tick of a fresh FIC with every error growing: each translational axis is in D, FIC = F_c(e) (Eq. 2, D),
    the moment is F_c(theta) r/theta with theta = |r| (the angle-axis FIC, fic_core/rotational_attractor.py), and
    tau_d = C qd + G + J^T FIC + tau_posture with every term computed here (with and without the feedforward
    J^T Lambda (a_d - Jdot qd) and the friction of the desired motion D M^-1 J^T Lambda xd_d)."""
    rng = np.random.default_rng(7)
    for trial in range(30):
        q, qd = random_state(rng)
        bias, minv, jacobian, drift, position, rotation = written_out_dynamics(robot, q, qd)
        # Errors of both signs, inside and beyond the linear region, and the orientation off by up to 0.6 rad.
        position_error = rng.uniform(-0.12, 0.12, 3)
        axis = rng.normal(size=3)
        rotation_error = axis / np.linalg.norm(axis) * rng.uniform(0.0, 0.6)
        desired_position = position + position_error
        desired_rotation = pin.exp3(rotation_error) @ rotation
        twist = jacobian @ qd
        # A desired twist that makes every |e| grow: d|e|/dt = sign(e) (xd_d - xd) > 0 on every translational
        # axis, and the angle: d theta/dt = (r/theta) . (w_d - w) > 0.
        angle = float(np.linalg.norm(rotation_error))
        desired_twist = twist + np.concatenate((np.sign(position_error) * rng.uniform(0.01, 0.2, 3),
                                                rotation_error / max(angle, 1e-300) * rng.uniform(0.01, 0.2)))
        with_feedforward = trial % 2 == 1
        acceleration = rng.normal(scale=1.0, size=6) if with_feedforward else None
        replica = ReplicaController(robot, PoseAttractor(ForceProfile(*TRANSLATION), ForceProfile(*ROTATION)),
                                    joint_damping_compensation=with_feedforward)
        command = replica.command(q, qd, desired_position, desired_rotation, desired_twist, acceleration)

        moment = profile_force(angle, *ROTATION) / angle * rotation_error if angle > 0.0 else np.zeros(3)
        wrench = np.concatenate(([profile_force(e, *TRANSLATION) for e in position_error], moment))
        expected = bias + jacobian.T @ wrench + written_out_posture(replica, q, qd, jacobian, minv)
        if with_feedforward:
            inertia = np.linalg.inv(jacobian @ minv @ jacobian.T + 1e-3 * np.eye(6))
            expected += jacobian.T @ inertia @ (acceleration - drift)
            expected += robot.joint_damping * (minv @ jacobian.T @ inertia @ desired_twist)
        np.testing.assert_allclose(command.unshaped_torque, expected, rtol=1e-7, atol=1e-7)
        np.testing.assert_array_equal(command.phase, np.zeros(6))


def test_eq_7_recomputed_through_a_convergence_swing(robot: RobotModel) -> None:
    """Four ticks of one state: an error that grows (D: F_c(e)), then decreases faster than the dead-band (enters C,
    latching e_max = the previous sample's error, K_C = min(2 F_c(e_max)/e_max, 8 V_D(e_max)/e_max^2) with V_D the
    integral of F_c: the C line K_C (e - e_max/2) of Eq. 2), keeps decreasing (stays on that line) and grows again
    (back in D where D's storage at the previous sample does not exceed C's, else still on the C line). tau_d is
    recomputed from Pinocchio at each tick; the storage integral by quadrature."""
    from scipy.integrate import quad

    rng = np.random.default_rng(8)
    q, qd = random_state(rng)
    replica = ReplicaController(robot, PoseAttractor(ForceProfile(*TRANSLATION), ForceProfile(*ROTATION)))
    bias, minv, jacobian, _, position, rotation = written_out_dynamics(robot, q, qd)
    twist = jacobian @ qd
    latched = np.array([0.02, -0.04, 0.07])  # inside the linear region (xi x_b = 25 mm), in and beyond saturation
    max_force = TRANSLATION[3]
    stiffness, latched_storage = [], []
    for e_max in latched:
        force = abs(profile_force(e_max, *TRANSLATION))
        storage = quad(lambda a: profile_force(a, *TRANSLATION), 0.0, abs(e_max), epsabs=1e-13, epsrel=1e-12)[0]
        stiffness.append(min(2.0 * force / abs(e_max), 8.0 * storage / e_max ** 2))
        latched_storage.append(storage)
    stiffness = np.array(stiffness)
    # At tick 3 an axis goes back to D only if V_D(e_{k-1}) <= V_C(e_{k-1}), e_{k-1} = e_max/2 where
    # V_C = V_latch - K_C e_max^2/8 (the C line's minimum); otherwise it stays on the C line (attractor.py).
    deferred = []
    for e_max, k_c, storage in zip(latched, stiffness, latched_storage):
        half = quad(lambda a: profile_force(a, *TRANSLATION), 0.0, abs(0.5 * e_max), epsabs=1e-13, epsrel=1e-12)[0]
        deferred.append(half > storage - k_c * e_max ** 2 / 8.0)
    deferred = np.array(deferred)
    assert not deferred.all() and deferred.any()  # both cases are met (F_max = 30 N: Eq. 1 stiffens)
    for tick, (errors, rate_sign) in enumerate(((latched, 1.0), (0.8 * latched, -1.0), (0.5 * latched, -1.0),
                                                 (0.6 * latched, 1.0))):
        desired_twist = twist.copy()
        desired_twist[:3] += rate_sign * np.sign(errors) * 0.1  # d|e|/dt = +0.1 (growing) or -0.1 m/s
        command = replica.command(q, qd, position + errors, rotation, desired_twist)
        line = np.clip(stiffness * (errors - 0.5 * latched), -max_force, max_force)
        profile = np.array([profile_force(e, *TRANSLATION) for e in errors])
        if tick in (1, 2):
            force, phase = line, [1, 1, 1]
        elif tick == 3:
            force, phase = np.where(deferred, line, profile), deferred.astype(int).tolist()
        else:
            force, phase = profile, [0, 0, 0]
        np.testing.assert_array_equal(command.phase[:3], phase, err_msg=f"tick {tick}")
        expected = bias + jacobian[:3].T @ force + written_out_posture(replica, q, qd, jacobian, minv)
        np.testing.assert_allclose(command.unshaped_torque, expected, rtol=1e-7, atol=1e-7, err_msg=f"tick {tick}")


# ---------------------------------------------------------------------------------------------------------------
# The postural optimisation, against its definition (postural_optimisation.py's docstring) solved by quadprog.

def written_out_acceleration_bounds(limits: PandaLimits, q, qd, dt: float, horizon: float):
    """Bounds on qdd, the tightest of: |qd + T qdd| <= v_max; the braking curve v L + v^2/2a = room on the next
    sample's velocity; q + dt (qd + dt qdd) inside the range (a joint inside its limits, |qd| <= v_max)."""
    deceleration = np.array(DEFAULT_BRAKING_DECELERATION)
    lag = horizon + BRAKING_TORQUE_RAMP
    v_max = limits.joint_velocity_array
    room_high = limits.upper_array - q
    room_low = q - limits.lower_array
    assert np.all(room_high > 0) and np.all(room_low > 0)
    brake_high = deceleration * (np.sqrt(lag ** 2 + 2.0 * room_high / deceleration) - lag)
    brake_low = -deceleration * (np.sqrt(lag ** 2 + 2.0 * room_low / deceleration) - lag)
    upper = np.minimum.reduce([(v_max - qd) / horizon, (brake_high - qd) / dt, (room_high / dt - qd) / dt])
    lower = np.maximum.reduce([(-v_max - qd) / horizon, (brake_low - qd) / dt, (-room_low / dt - qd) / dt])
    return lower, upper


def quadprog_solution(limits: PandaLimits, q, qd, desired, previous, bias, minv, dt: float, horizon: float):
    """argmin 1/2 (tau - tau_d)^T M^-1 (tau - tau_d) over the hard box and the joint rows, or None if infeasible."""
    step = limits.torque_rate * dt
    torque_max = limits.torque_array
    box_low = np.maximum(-torque_max, previous - step)
    box_high = np.minimum(torque_max, previous + step)
    acceleration_low, acceleration_high = written_out_acceleration_bounds(limits, q, qd, dt, horizon)
    if np.any(acceleration_low > acceleration_high):
        return None
    free = minv @ bias
    # quadprog: min 1/2 x^T G x - a^T x s.t. C^T x >= b.
    hessian = 0.5 * (minv + minv.T)
    identity = np.eye(7)
    constraints = np.hstack([identity, -identity, minv.T, -minv.T])
    bounds = np.concatenate([box_low, -box_high, acceleration_low + free, -(acceleration_high + free)])
    try:
        solution = quadprog.solve_qp(hessian, hessian @ desired, constraints, bounds)[0]
    except ValueError:  # "constraints are inconsistent, no solution"
        return None
    return solution


def test_qp_answer_is_the_optimum_of_its_definition(robot: RobotModel, limits: PandaLimits) -> None:
    """Random states inside the limits with demands that break the box or the joint rows (the TCP speed kept
    below its limit, so the QP is the one quadprog solves): the command equals quadprog's optimum, the last-guard
    clip never acts, and the answer is feasible for the written-out constraints."""
    optimisation = PosturalOptimisation(limits, DT)
    rng = np.random.default_rng(31)
    compared = feasible = 0
    for _ in range(400):
        q = rng.uniform(limits.lower_array + 0.02, limits.upper_array - 0.02)
        qd = rng.uniform(-0.95, 0.95, 7) * limits.joint_velocity_array * rng.uniform(0.0, 1.0)
        bias_model, minv, jacobian, _, _, _ = written_out_dynamics(robot, q, qd)
        if np.linalg.norm(jacobian[:3] @ qd) > 0.8 * limits.tcp_speed:
            continue
        bias = bias_model + robot.joint_damping * qd
        previous = bias_model + rng.normal(scale=3.0, size=7)
        previous = np.clip(previous, -limits.torque_array, limits.torque_array)
        desired = previous + rng.normal(scale=rng.choice([0.5, 5.0, 50.0]), size=7)
        result = optimisation.shape(desired, previous, q, qd, bias, minv, jacobian[:3])
        expected = quadprog_solution(limits, q, qd, desired, previous, bias, minv, DT, optimisation.horizon)
        # Relaxed exactly when quadprog finds the hard problem infeasible.
        assert result.relaxed == (expected is None)
        if expected is None:
            continue
        assert not result.guard_clipped  # a feasible QP: the solver's answer needs no clip
        feasible += 1
        ahead = jacobian[:3] @ (qd + optimisation.horizon * minv @ (expected - bias))
        if np.linalg.norm(ahead) >= limits.tcp_speed * (1.0 - 2e-3):
            continue  # a TCP cut may be active: not the QP quadprog solved
        compared += 1
        scale = 1.0 + np.linalg.norm(desired - expected)
        np.testing.assert_allclose(result.torque, expected, atol=1e-6 * scale)
        # Feasible for the written-out constraints (the hard box exactly, the rows to the solver's tolerance).
        step = limits.torque_rate * DT
        assert np.all(np.abs(result.torque) <= limits.torque_array + 1e-9)
        assert np.all(np.abs(result.torque - previous) <= step + 1e-9)
        low, high = written_out_acceleration_bounds(limits, q, qd, DT, optimisation.horizon)
        acceleration = minv @ (result.torque - bias)
        assert np.all(acceleration >= low - 1e-6 * (1.0 + np.abs(low)))
        assert np.all(acceleration <= high + 1e-6 * (1.0 + np.abs(high)))
        if np.array_equal(result.torque, desired):
            assert result.flags == LimitFlag.NONE
        else:
            assert result.flags != LimitFlag.NONE and result.solved_qp
    assert compared > 250, compared
    assert feasible > 300, feasible


def test_the_replica_never_needs_the_last_guard_on_feasible_states(robot: RobotModel, limits: PandaLimits) -> None:
    """ReplicaController on random states inside every limit, with stiff demands that the QP must shape: the
    solver's answer is inside the torque and torque-rate box by itself (guard_clipped false on every tick)."""
    rng = np.random.default_rng(32)
    position = written_out_dynamics(robot, NOMINAL_CONFIGURATION, np.zeros(7))[4]
    rotation = written_out_dynamics(robot, NOMINAL_CONFIGURATION, np.zeros(7))[5]
    replica = ReplicaController(robot, PoseAttractor(ForceProfile(2000.0, 0.05, 0.5, 200.0),
                                                     ForceProfile(100.0, 0.5, 0.5, 30.0)))
    qp_ticks = 0
    for _ in range(400):
        q = rng.uniform(limits.lower_array + 0.05, limits.upper_array - 0.05)
        qd = rng.uniform(-0.5, 0.5, 7) * limits.joint_velocity_array
        bias = written_out_dynamics(robot, q, qd)[0]
        replica.reset(previous_torque=np.clip(bias, -limits.torque_array, limits.torque_array))
        command = replica.command(q, qd, position + rng.normal(scale=0.2, size=3), rotation)
        if command.relaxed:
            continue
        assert not command.guard_clipped
        qp_ticks += command.solved_qp
    assert qp_ticks > 100, qp_ticks
