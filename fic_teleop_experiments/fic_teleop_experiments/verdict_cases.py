"""The run verdict's labelled validation set: runs whose answer is known before the verdict sees them
(docs/EXPERIMENTS.md, "The verdict's validation").

(a) BOUNDARY. A mass with damping under DELAYED position feedback, m x'' + D x' + K x(t - tau) = 0, the replica's
    position loop closed through the channel's round trip tau. At s = j w the characteristic equation
    m s^2 + D s + K e^(-s tau) = 0 gives K e^(-j w tau) = m w^2 - j D w, so the loop crosses into instability at
        w tau = atan(D / (m w)),   K_crit = w sqrt(m^2 w^2 + D^2)
    (the D-subdivision of a retarded system: Stepan 1989, "Retarded dynamical systems: stability and characteristic
    functions", ch. 2; below K_crit every root is in the left half plane for this second-order loop). Simulated at
    0.9 and 1.1 K_crit after a push: stable, unstable.
(b) LIMIT CYCLES on stable runs. The stable reference is a position-position bilateral teleoperator through a delay
    T each way (handle 0.5 kg, replica 4 kg, coupling K = 200 N/m each way on the other side's delayed offset, local
    damping B = 1.5 K T + 5 N s/m: above the margin B > K T of Lee and Spong 2006, "Passive bilateral teleoperation
    with constant time delay", IEEE T-RO 22(2)), driven by an operator's hand (a 300 N/m spring-damper) towards
    targets moved at random times, by random amounts, over random durations, and by a planner moving the replica's
    set point the same way (the task does not repeat). A limit cycle of 5, 10, 20 or 30 mm amplitude at 0.5, 1, 2.5,
    5, 10 or 16 s is added to its motion (x_M, and x_d, x_R a quarter and half a period later) and its kinetic energy:
    unstable. The reference runs themselves, at 0, 0.2, 1 and 2 s each way: stable. The same loop on a task that
    repeats like the paper's (a planner circling 0.10 m at a lap of 4.5-5.5 s, one avoid move a lap): stable, and
    with 5, 10, 10, 20 mm limit cycles at 1, 2.5, 5 (the lap), 10 s: unstable.
(c) Runs that fooled the older verdict: parked 150 mm off the target in free motion (unstable: parked); a crash into
    the obstacle the task steers around every 5 s, each with a burst of channel generation (stable, NOT SAFE:
    repeated collisions, the motion between them is the stable loop's); one collision with its burst (stable and
    safe: the burst is contact's, not steady generation); holding a push into a wall with 210 mm between set point
    and TCP (stable and safe: contact, not instability); the same loop with a channel that adds energy along the
    handle's motion, damped away by the handle's damping so that the motion stays bounded, alone and beside one
    collision (unstable: steady generation at the ports); a limit-violation run and a velocity-reflex trip (stable,
    NOT SAFE).
(a', b', c') A stable loop that answers its command with a resonance, told from a loop that oscillates by itself.
    (a') A RESONANT REPLICA, FORCED: a second-order replica m x_R'' = K (x_d - x_R) - D x_R' (4 kg, natural
    frequency 0.75 Hz, damping ratio 0.29: peak gain 1/(2 zeta sqrt(1 - zeta^2)) = 1.80 at 1.46 s; stable, its
    poles in the left half plane for any m, D, K > 0), following x_d = planner + the handle one delay later, at full
    rate and sample-and-held at 10 Hz, the handle following the operator's target on a spring-damper hand: a cascade
    of stable parts, stable at any delay and hold. Driven by a task like the claims' (a circle whose lap and diameter
    vary per lap, the operator's moves at random times and a hand never still), it swings about its command by its
    forced answer: stable, at 0.2 and 1 s. (b') The same runs with a limit cycle of 5, 10, 20, 30 mm at the resonant
    period on the replica alone (independent of the command): unstable. (c') The handle held by a hand that corrects
    what it saw of the handle's offset one reaction time and one round trip ago, with a saturating force, at 1.5 x
    the K_crit of (a)'s closed form for that loop: a limit cycle that the command carries to the replica (the command
    holds the loop's own oscillation, so only an exogenous input may excuse anything): unstable.

(a'', b'') A stable under-damped loop driven by a reactive hand: the resonant replica of (a') held by (c')'s hand at
    0.5 K_crit (a hand whose delayed correction rings but decays): stable; the same with a 5 mm limit cycle at the
    resonant period that goes on through the quiet tail: unstable.
(d) A DELAYED SPRING-DAMPER at its critical delay (``critical_delay``, derived there): its set point moved for 30 s,
    then held still; at 0.9 T_crit stable, at 1.1 T_crit unstable.

THE QUIET TAIL. Every case ends with one (``tail_for``: what the run verdict judges its free response on, as a claim
run's). (a) is a free response throughout, its series unchanged; (b), (a'), (b'), (c'), (c) continue after their task
with the planner and the operator's target held at their last values while the loop runs on; the added limit cycles
go on through the tail; the strikes of "crash every lap" happen during the task only.

Every case is deterministic (seeded); ``cases()`` builds them all in under a minute.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq
from scipy.signal import butter, lfilter

from fic_teleop_tools.verdict.run_verdict import VerdictCriterion, VerdictInput

STEP = 0.001          # [s] integration step
SAMPLE = 0.01         # [s] the series' period (the runner's 100 Hz poses)
HANDLE_MASS, REPLICA_MASS = 0.5, 4.0
FEEDBACK_STIFFNESS, HANDLE_DAMPING = 50.0, 5.0        # the handle's coupling to the delayed replica offset
REPLICA_STIFFNESS, REPLICA_DAMPING = 200.0, 40.0      # the replica's to the delayed handle (damping ratio 0.71)
HAND_STIFFNESS, HAND_DAMPING = 300.0, 10.0
WALL_STIFFNESS, WALL_DAMPING = 5000.0, 50.0
REFERENCE_DELAYS = (0.0, 0.2, 1.0, 2.0)
CYCLE_DELAYS = (0.2, 1.0, 2.0)
CYCLE_AMPLITUDES = (0.005, 0.010, 0.020, 0.030)
CYCLE_PERIODS = (0.5, 1.0, 2.5, 5.0, 10.0, 16.0)
COLLISION_BURST_J = 2.7   # [J] a collision's burst at the ports: the median of the claim runs' bursts (1.4-13.9 J)
DURATION = 40.0       # [s] the task: holds 1.5 periods of 16 s (4 round trips at 2 s) after the 2 s of settling


def tail_for(one_way_delay: float) -> float:
    """[s] the quiet tail a case ends with: the least the run verdict judges (VerdictCriterion.tail_needed), as the
    claim runs' (fic_teleop_experiments.claims.tail_for)."""
    return VerdictCriterion().tail_needed(one_way_delay)


def _held_from(series: NDArray, index: int) -> NDArray:
    """``series`` (n, ...) with every sample from ``index`` on held at the one before: an input stopped there."""
    out = np.array(series, dtype=float, copy=True)
    if 0 < index < out.shape[0]:
        out[index:] = out[index - 1]
    return out


@dataclass
class LabelledCase:
    name: str
    group: str
    stable: bool
    safe: bool
    data: VerdictInput
    why: str


def critical_gain(mass: float, damping: float, tau: float) -> tuple[float, float]:
    """(K_crit [N/m], w [rad/s]) of m x'' + D x' + K x(t - tau) = 0 (module docstring, (a))."""
    frequency = brentq(lambda w: w * tau - math.atan(damping / (mass * w)), 1e-9, 1e4)
    return frequency * math.sqrt(mass ** 2 * frequency ** 2 + damping ** 2), frequency


def delayed_feedback(gain: float, mass: float, damping: float, tau: float, duration: float, push: float = 0.05
                     ) -> VerdictInput:
    """(a): the mass starts at rest with ``push`` m/s; set point 0, so x_d - x_R = -x. Nothing moves it after the
    push, so the whole run is its free response; the quiet tail the verdict judges is the run's last ``tail_for``
    seconds, as a claim run's is."""
    steps, lag, every = int(round(duration / STEP)), int(round(tau / STEP)), int(round(SAMPLE / STEP))
    history = [0.0] * steps
    position, velocity = 0.0, push
    times, xs, vs = [], [], []
    for k in range(steps):
        history[k] = position
        seen = history[k - lag] if k >= lag else 0.0
        velocity += (-damping * velocity - gain * seen) / mass * STEP
        position += velocity * STEP
        if k % every == 0:
            times.append(k * STEP), xs.append(position), vs.append(velocity)
    time, x, v = np.array(times), np.array(xs), np.array(vs)
    zero = np.zeros((time.size, 3))
    tcp = zero.copy()
    tcp[:, 0] = x
    return VerdictInput(time=time, one_way_delay=0.5 * tau, x_R=tcp, x_d=zero, command=zero,
                        arm_kinetic_energy=0.5 * mass * v ** 2, limit_violations=0, reflex_trips=0, safe_holds=0,
                        stale_holds=0, source="delayed feedback", quiet_from=duration - tail_for(0.5 * tau))


def critical_delay(mass: float, damping: float, stiffness: float) -> tuple[float, float]:
    """(T_crit [s], w [rad/s]) of the delayed spring-damper m x'' + b x' + k x(t - T) = 0 (m, b, k > 0).

    Its characteristic equation is m s^2 + b s + k e^(-s T) = 0. At T = 0 both roots are in the left half plane
    (Routh-Hurwitz). Roots cross the imaginary axis only at s = j w with k e^(-j w T) = m w^2 - j b w; the moduli give
        k^2 = m^2 w^4 + b^2 w^2,   so   w^2 = (sqrt(b^4 + 4 m^2 k^2) - b^2) / (2 m^2)   (one crossing frequency),
    and the phases cos(w T) = m w^2 / k, sin(w T) = b w / k, so the first crossing is at
        T_crit = atan2(b w, m w^2) / w   (below pi/2 / w: the oscillation born there has a period over 4 T).
    At that single frequency every crossing is from left to right (for m s^2 + b s + k e^(-s T), sign Re(ds/dT) =
    sign of the derivative of |m w^2 - j b w|^2 - k^2 in w^2 = 2 m^2 w^2 + b^2 > 0: Cooke and van den Driessche 1986,
    "On zeroes of some transcendental equations", Funkcial. Ekvac. 29; Stepan 1989, ch. 2): stable for every
    T < T_crit, unstable for every T > T_crit."""
    frequency = math.sqrt((math.sqrt(damping ** 4 + 4.0 * mass ** 2 * stiffness ** 2) - damping ** 2)
                          / (2.0 * mass ** 2))
    return math.atan2(damping * frequency, mass * frequency ** 2) / frequency, frequency


def delayed_spring_damper(factor: float, seed: int, mass: float = 4.0, damping: float = 40.0, stiffness: float = 100.0,
                          task: float = 30.0) -> VerdictInput:
    """A replica whose position loop is closed through a delay T = ``factor`` x T_crit (``critical_delay``):
    m x'' + b x' + k (x(t - T) - x_d(t - T)) = 0, its set point x_d moved like a planner's (aperiodic moves of up to
    40 mm) for ``task`` seconds and then held still for the quiet tail (``tail_for`` of T / 2 each way: the loop's
    delay is a round trip). Stable for factor < 1, unstable above (``critical_delay``)."""
    tau, _ = critical_delay(mass, damping, stiffness)
    tau *= factor
    tail = tail_for(0.5 * tau)
    steps, lag, every = int(round((task + tail) / STEP)), int(round(tau / STEP)), int(round(SAMPLE / STEP))
    fine = np.arange(steps) * STEP
    set_point = _held_from(_moves(np.random.default_rng([seed, 4111]), fine, (0.8, 3.0), 0.04, (0.4, 1.2)),
                           int(round(task / STEP)))
    history = np.zeros(steps)
    position = velocity = 0.0
    rows = []
    for k in range(steps):
        history[k] = position - set_point[k]
        seen = history[k - lag] if k >= lag else 0.0
        velocity += (-damping * velocity - stiffness * seen) / mass * STEP
        position += velocity * STEP
        if k % every == 0:
            rows.append((k * STEP, position, set_point[k], 0.5 * mass * velocity ** 2))
    a = np.array(rows)
    time = a[:, 0]
    spatial = np.zeros((time.size, 3)), np.zeros((time.size, 3))
    spatial[0][:, 0], spatial[1][:, 0] = a[:, 1], a[:, 2]
    return VerdictInput(time=time, one_way_delay=0.5 * tau, x_R=spatial[0], x_d=spatial[1], command=spatial[1],
                        planner=spatial[1], arm_kinetic_energy=a[:, 3], force=np.zeros((time.size, 3)),
                        contact=np.zeros(time.size, dtype=bool), limit_violations=0, reflex_trips=0, safe_holds=0,
                        stale_holds=0, source=f"delayed spring-damper at {factor:g} T_crit, seed {seed}",
                        quiet_from=task)


def _moves(rng: np.random.Generator, time: NDArray, gap: tuple[float, float], reach: float,
           duration: tuple[float, float]) -> NDArray:
    """A target moved at random times (gaps drawn in ``gap``) to random places in [-reach, reach], each move a raised
    cosine over a duration drawn in ``duration``: aperiodic, as an operator's or a re-planned motion is."""
    target = np.zeros(time.size)
    when, where = 1.0 + rng.uniform(*gap) * 0.5, 0.0
    while when < time[-1]:
        goal, length = rng.uniform(-reach, reach), rng.uniform(*duration)
        phase = np.clip((time - when) / length, 0.0, 1.0)
        target = np.where(time >= when, where + (goal - where) * 0.5 * (1.0 - np.cos(np.pi * phase)), target)
        where, when = goal, when + length + rng.uniform(*gap)
    return target


def loop_gain_peak(frequencies: NDArray | None = None) -> float:
    """max over w of |L(jw)|, the reference loop's gain around master -> replica -> master without the delay:
    L = K_M / (m_M s^2 + (B_M + c_h) s + K_M + k_h) * (B_R s + K_R) / (m_R s^2 + B_R s + K_R) (the hand holds
    the handle). Under 1, the loop is stable for ANY constant delay (the small-gain theorem; the delay has gain 1)."""
    w = np.geomspace(1e-3, 1e4, 20000) if frequencies is None else frequencies
    s = 1j * w
    handle = FEEDBACK_STIFFNESS / (HANDLE_MASS * s ** 2 + (HANDLE_DAMPING + HAND_DAMPING) * s
                                   + FEEDBACK_STIFFNESS + HAND_STIFFNESS)
    replica = (REPLICA_DAMPING * s + REPLICA_STIFFNESS) / (REPLICA_MASS * s ** 2 + REPLICA_DAMPING * s
                                                          + REPLICA_STIFFNESS)
    return float(np.abs(handle * replica).max())


def _circling(rng: np.random.Generator, time: NDArray) -> tuple[NDArray, NDArray]:
    """(planner, hand target) of a task like the paper's: the planner circles (0.10 m radius, each lap's period drawn
    in 4.5-5.5 s), the operator makes one 30 mm avoid move a lap (1.2-1.8 s, at a drawn phase), plus small random
    moves. Periodic at the lap, so the loop's answer to it is too."""
    periods = rng.uniform(4.5, 5.5, int(time[-1] / 4.5) + 2)
    starts = np.concatenate([[0.0], np.cumsum(periods)])
    lap = np.searchsorted(starts, time, side="right") - 1
    phase = 2.0 * np.pi * (lap + (time - starts[lap]) / periods[lap])
    planner = 0.10 * np.sin(phase)
    target = _moves(rng, time, (2.0, 6.0), 0.01, (0.5, 1.5))
    for k in range(len(periods)):
        when, length = starts[k] + rng.uniform(1.0, 2.0), rng.uniform(1.2, 1.8)
        inside = (time >= when) & (time < when + length)
        target[inside] += 0.03 * 0.5 * (1.0 - np.cos(2.0 * np.pi * (time[inside] - when) / length))
    return planner, target


def bilateral(delay: float, seed: int, duration: float = DURATION,
              wall: tuple[float, float, float] | None = None, circling: bool = False,
              tail: float | None = None) -> VerdictInput:
    """(b)'s reference loop (module docstring). ``wall`` (from, to, position): between those times the operator
    pushes the replica towards a wall at that x, which the replica cannot pass (the F/T force is the wall's).
    ``circling``: the task of ``_circling`` instead of the aperiodic one. ``duration``: the task; the quiet tail of
    ``tail`` seconds (None: ``tail_for``) follows it, the operator's target and the planner held still."""
    tail = tail_for(delay) if tail is None else tail
    rng = np.random.default_rng([seed, int(delay * 1000)])
    steps, lag, every = int(round((duration + tail) / STEP)), int(round(delay / STEP)), int(round(SAMPLE / STEP))
    fine = np.arange(steps) * STEP
    if circling:
        planner, target = _circling(rng, fine)
    else:
        target = _moves(rng, fine, (1.5, 5.0), 0.04, (0.4, 1.5))
        planner = _moves(rng, fine, (2.0, 6.0), 0.08, (1.0, 2.5))
    if wall is not None:
        start, end, place = wall
        planner[fine >= start - 1.0] = planner[int((start - 1.0) / STEP)]   # the planner holds during the push
        push = np.clip((fine - start) / 1.0, 0.0, 1.0) * np.clip((end - fine) / 1.0, 0.0, 1.0)
        target = target * (1.0 - push) + push * (place + 0.25 - planner)
    quiet = int(round(duration / STEP))
    target, planner = _held_from(target, quiet), _held_from(planner, quiet)
    planner_velocity = np.gradient(planner, STEP)
    y_master, y_replica, v_master, v_replica = np.zeros(steps), np.zeros(steps), np.zeros(steps), np.zeros(steps)
    x_m = v_m = x_r = v_r = 0.0
    work = 0.0
    rows = []
    for k in range(steps):
        y_master[k], y_replica[k] = x_m, x_r - planner[k]
        v_master[k], v_replica[k] = v_m, v_r - planner_velocity[k]
        seen_replica = y_replica[k - lag] if k >= lag else 0.0
        seen_master = y_master[k - lag] if k >= lag else 0.0
        seen_master_velocity = v_master[k - lag] if k >= lag else 0.0
        channel_master = FEEDBACK_STIFFNESS * (seen_replica - x_m)
        channel_replica = REPLICA_STIFFNESS * (seen_master - y_replica[k]) + REPLICA_DAMPING * (
            seen_master_velocity - v_replica[k])
        contact = 0.0
        if wall is not None and x_r > wall[2]:
            contact = -WALL_STIFFNESS * (x_r - wall[2]) - WALL_DAMPING * v_r
        hand = HAND_STIFFNESS * (target[k] - x_m) - HAND_DAMPING * v_m
        v_m += (channel_master + hand - HANDLE_DAMPING * v_m) / HANDLE_MASS * STEP
        v_r += (channel_replica + contact) / REPLICA_MASS * STEP
        x_m += v_m * STEP
        x_r += v_r * STEP
        # What the channel's two couplings put into the masses (the channel's ports), net of their springs' storage.
        work += (channel_master * v_m + channel_replica * (v_r - planner_velocity[k])) * STEP
        storage = 0.5 * FEEDBACK_STIFFNESS * (seen_replica - x_m) ** 2 \
            + 0.5 * REPLICA_STIFFNESS * (seen_master - (x_r - planner[k])) ** 2
        if k % every == 0:
            rows.append((k * STEP, x_m, x_r, planner[k] + seen_master, target[k], planner[k],
                         0.5 * REPLICA_MASS * v_r ** 2, 0.5 * HANDLE_MASS * v_m ** 2, work + storage, -contact))
    a = np.array(rows)
    time = a[:, 0]
    target_sampled, planner_sampled = a[:, 4], a[:, 5]
    command = planner_sampled + np.interp(time - delay, time, target_sampled)

    def spatial(x: NDArray) -> NDArray:
        out = np.zeros((x.size, 3))
        out[:, 0] = x
        return out

    return VerdictInput(time=time, one_way_delay=delay, x_M=spatial(a[:, 1]), x_R=spatial(a[:, 2]),
                        x_d=spatial(a[:, 3]), operator_target=spatial(target_sampled), command=spatial(command),
                        planner=spatial(planner_sampled),
                        arm_kinetic_energy=a[:, 6], handle_kinetic_energy=a[:, 7], channel_generated=a[:, 8],
                        force=spatial(a[:, 9]), contact=np.zeros(time.size, dtype=bool), limit_violations=0,
                        reflex_trips=0, safe_holds=0, stale_holds=0, source=f"bilateral {delay:g} s seed {seed}",
                        quiet_from=duration if tail > 0.0 else None)


def pumping(data: VerdictInput, rate: float = 0.1) -> VerdictInput:
    """(c): ``rate`` watts of generation added to the channel's series from the start, the motion unchanged (the
    damping takes the energy away as fast as the channel makes it)."""
    return replace(data, channel_generated=data.channel_generated + rate * (data.time - data.time[0]),
                   source=f"{data.source}, channel pumping {rate * 1e3:g} mW")


def with_limit_cycle(data: VerdictInput, amplitude: float, period: float) -> VerdictInput:
    """(b): a steady oscillation on the handle, the set point a quarter period later, the TCP half a period later,
    with its kinetic energy; the rest of the run unchanged."""
    w = 2.0 * math.pi / period
    t = data.time

    def swing(lag: float) -> NDArray:
        out = np.zeros((t.size, 3))
        out[:, 0] = amplitude * np.sin(w * t - lag)
        return out

    speed = amplitude * w * np.cos(w * t)
    return replace(data, x_M=data.x_M + swing(0.0), x_d=data.x_d + swing(0.5 * math.pi), x_R=data.x_R + swing(math.pi),
                   handle_kinetic_energy=data.handle_kinetic_energy + 0.5 * HANDLE_MASS * speed ** 2,
                   arm_kinetic_energy=data.arm_kinetic_energy + 0.5 * REPLICA_MASS * speed ** 2,
                   source=f"{data.source} + {amplitude * 1e3:g} mm at {period:g} s")


def parked(data: VerdictInput, offset: float = 0.15, after: float = 12.0) -> VerdictInput:
    """(c): from ``after`` on the TCP stays ``offset`` off (in y) where the loop put it, in free motion."""
    shift = np.zeros_like(data.x_R)
    shift[data.time >= after, 1] = offset
    return replace(data, x_R=data.x_R + shift, source=f"{data.source}, parked {offset * 1e3:g} mm")


def crash_every_lap(data: VerdictInput, lap: float = 5.0, length: float = 0.4, force: float = 30.0) -> VerdictInput:
    """(c): every ``lap`` seconds the TCP strikes the obstacle the task steers around (contact flag, an F/T impact of
    ``force`` newtons for ``length`` seconds, the TCP stopped 20 mm short of where it would have gone)."""
    phase = (data.time - 3.0) % lap
    # During the task only: in the quiet tail nothing moves the arm toward the obstacle.
    task = data.time < (data.quiet_from if data.quiet_from is not None else np.inf)
    touching = (data.time >= 3.0) & (phase < length) & task
    pulse = np.zeros_like(data.x_R)
    pulse[touching, 0] = force * np.sin(np.pi * phase[touching] / length)
    stopped = np.zeros_like(data.x_R)
    stopped[touching, 1] = -0.02 * np.sin(np.pi * phase[touching] / length)
    return replace(data, contact=touching, force=data.force + pulse, x_R=data.x_R + stopped,
                   channel_generated=data.channel_generated + _bursts(data, touching),
                   source=f"{data.source}, crash every {lap:g} s")


def _bursts(data: VerdictInput, touching: NDArray, energy: float = COLLISION_BURST_J) -> NDArray:
    """What a collision through the delay adds to the channel's generated energy: ``energy`` joules per contact
    episode, spread over the episode and the round trip after it (the force reaches the handle one delay after the
    hit and the hand's answer the replica another delay later), then kept: the loop damps it away, the channel's
    books keep it."""
    rising = np.flatnonzero(touching[1:] & ~touching[:-1]) + 1
    falling = np.flatnonzero(touching[:-1] & ~touching[1:]) + 1
    added = np.zeros(data.time.size)
    for start, end in zip(rising, falling):
        ramp_end = data.time[end - 1] + 2.0 * data.one_way_delay
        added += energy * np.clip((data.time - data.time[start]) / (ramp_end - data.time[start]), 0.0, 1.0)
    return added


def one_collision(data: VerdictInput, at: float = 15.0, length: float = 0.5, force: float = 80.0) -> VerdictInput:
    """(c): one collision with the obstacle the task steers around, the F/T impact and the channel's burst with it
    (``_bursts``), the motion otherwise the stable run's."""
    touching = (data.time >= at) & (data.time < at + length)
    pulse = np.zeros_like(data.x_R)
    pulse[touching, 0] = force * np.sin(np.pi * (data.time[touching] - at) / length)
    return replace(data, contact=touching, force=data.force + pulse,
                   channel_generated=data.channel_generated + _bursts(data, touching),
                   source=f"{data.source}, one collision at {at:g} s")


#: The resonant replica of the forced-answer cases: m x_R'' = K (x_d - x_R) - D x_R' with K = m w_n^2, D = 2 zeta m w_n.
RESONANT_MASS, RESONANT_NATURAL_HZ, RESONANT_DAMPING_RATIO = 4.0, 0.75, 0.29
RESONANT_DELAYS, RESONANT_RATES_HZ = (0.2, 1.0), (0.0, 10.0)
HAND_LOOP_MASS, HAND_LOOP_DAMPING, HAND_LOOP_REACTION, HAND_LOOP_SATURATION = 0.5, 5.0, 0.2, 0.01
#: The reactive hand of the stable driven case: its loop gain as a factor of its K_crit.
HAND_LOOP_STABLE = 0.5
#: The delayed spring-damper's stiffnesses [N/m] (m 4 kg, b 40 N s/m): T_crit 0.55 s and 0.25 s.
CRITICAL_DELAY_STIFFNESSES = (100.0, 200.0)


def resonance(mass: float = RESONANT_MASS, natural_hz: float = RESONANT_NATURAL_HZ,
              damping_ratio: float = RESONANT_DAMPING_RATIO) -> tuple[float, float, float, float]:
    """(K [N/m], D [N s/m], peak gain, period of the peak [s]) of the resonant replica: K / (m s^2 + D s + K) peaks at
    1 / (2 zeta sqrt(1 - zeta^2)) at w_n sqrt(1 - 2 zeta^2) (zeta < 1/sqrt 2). Its poles have negative real parts for
    every m, D, K > 0 (Routh-Hurwitz for a second-order polynomial): stable."""
    w = 2.0 * math.pi * natural_hz
    peak = 1.0 / (2.0 * damping_ratio * math.sqrt(1.0 - damping_ratio ** 2))
    period = 2.0 * math.pi / (w * math.sqrt(1.0 - 2.0 * damping_ratio ** 2))
    return mass * w * w, 2.0 * damping_ratio * mass * w, peak, period


def _claim_like_task(rng: np.random.Generator, time: NDArray) -> tuple[NDArray, NDArray]:
    """(planner (n, 3), operator target (n, 3)) with the claim task's spectrum: a circle in x-y whose lap period
    (4.5-5.5 s) and diameter (0.17-0.23 m) are drawn per lap and blended, and the operator's moves at random times
    (to places within 40 mm, over 0.5-1.2 s, 0.8-3 s apart) plus a wander (within 15 mm, over 0.8-2.5 s) on every
    axis, and band-limited noise at 0.60-0.72 Hz (8 mm RMS an axis): nothing repeats. The operator's part has about
    the claim runs' power at 0.4-1 Hz, where the resonance is (8-14 mm RMS on the two axes the claim operator moves
    most, 1 s delay at 10 Hz, seed 3), and the continuous narrow band the reactive hand adds there."""
    laps = int(time[-1] / 4.5) + 2
    periods, diameters = rng.uniform(4.5, 5.5, laps), rng.uniform(0.17, 0.23, laps + 1)
    starts = np.concatenate([[0.0], np.cumsum(periods)])
    lap = np.searchsorted(starts, time, side="right") - 1
    within = (time - starts[lap]) / periods[lap]
    angle = 2.0 * math.pi * (lap + within) + rng.uniform(0.0, 2.0 * math.pi)
    radius = 0.5 * (diameters[lap] + (diameters[lap + 1] - diameters[lap]) * within)
    planner = np.column_stack([radius * np.cos(angle), radius * np.sin(angle), np.zeros(time.size)])
    target = np.column_stack([_moves(rng, time, (0.8, 3.0), 0.04, (0.5, 1.2))
                              + _moves(rng, time, (0.3, 1.5), 0.015, (0.8, 2.5)) for _ in range(3)])
    # The hand never still: noise band-passed to 0.60-0.72 Hz (Butterworth, first order; 8 mm RMS an axis), the
    # narrow-band part of the offset the replica receives in the claim runs' controls (the reactive hand's few
    # millimetres at 0.6-0.7 Hz).
    step = float(time[1] - time[0])
    b, a = butter(1, [0.60, 0.72], btype="bandpass", fs=1.0 / step)
    hum = lfilter(b, a, rng.standard_normal((time.size, 3)), axis=0)
    target += 0.008 * hum / hum.std(axis=0)
    return planner, target


def resonant_plant(delay: float, seed: int, rate_hz: float = 0.0, duration: float = 30.0,
                   hand_loop_gain: float | None = None, tail: float | None = None) -> VerdictInput:
    """A stable, under-damped replica (``resonance``) following x_d = planner + the handle one delay later, held at
    ``rate_hz`` (0: every step), the handle following the operator's target on a 300 N/m, 15 N s/m hand (0.5 kg): a
    cascade of stable parts, stable for any delay and hold, its answer to the command resonant (gain about 1.8 at
    about 1.46 s). No force comes back: what the replica does about its command is its forced answer.

    ``hand_loop_gain`` (a factor of K_crit): the handle is instead held on its target by a hand that corrects what it
    saw of the handle's offset one reaction time plus one round trip ago (it sees it through the replica), with a
    saturating force: m y'' + D y' + K sat(y(t - tau)) = -(m target'' + D target'), y = x_M - target,
    tau = reaction + 2 delay. Its linear part is the delayed loop of (a): above K_crit it is unstable and the
    saturation makes it a limit cycle, which the command (the handle one delay later) carries to the replica. The
    handle starts ``HAND_LOOP_SATURATION`` off its target on every axis. Below K_crit (a hand loop gain under 1) the
    hand is a reactive one that the loop keeps stable.

    ``duration``: the task; the quiet tail of ``tail`` seconds (None: ``tail_for``) follows it, the planner and the
    operator's target held still, the link and the hand running on."""
    tail = tail_for(delay) if tail is None else tail
    rng = np.random.default_rng([seed, int(delay * 1000), int(rate_hz), 7])
    stiffness, damping, _, _ = resonance()
    steps, lag, every = int(round((duration + tail) / STEP)), int(round(delay / STEP)), int(round(SAMPLE / STEP))
    hold = int(round(1.0 / (rate_hz * STEP))) if rate_hz > 0.0 else 1
    fine = np.arange(steps) * STEP
    planner, target = _claim_like_task(rng, fine)
    quiet = int(round(duration / STEP))
    planner, target = _held_from(planner, quiet), _held_from(target, quiet)
    target_velocity = np.gradient(target, STEP, axis=0)
    loop_gain, loop_lag = 0.0, 0
    if hand_loop_gain is not None:
        tau = HAND_LOOP_REACTION + 2.0 * delay
        loop_gain = hand_loop_gain * critical_gain(HAND_LOOP_MASS, HAND_LOOP_DAMPING, tau)[0]
        loop_lag = int(round(tau / STEP))
    handle_history = np.zeros((steps, 3))
    x_m, v_m, x_r, v_r = np.zeros(3), np.zeros(3), planner[0].copy(), np.zeros(3)
    if hand_loop_gain is not None:
        x_m = np.full(3, HAND_LOOP_SATURATION)   # the handle starts off its target, as (a)'s mass starts pushed
    received = np.zeros(3)
    rows = []
    for k in range(steps):
        handle_history[k] = x_m
        if k % hold == 0:   # the link delivers the handle one delay ago; the replica holds it until the next slot
            received = handle_history[k - lag] if k >= lag else np.zeros(3)
        x_d = planner[k] + received
        if hand_loop_gain is None:
            hand = HAND_STIFFNESS * (target[k] - x_m) + HAND_DAMPING * 1.5 * (target_velocity[k] - v_m)
            v_m = v_m + hand / HANDLE_MASS * STEP
        else:
            seen = handle_history[k - loop_lag] - target[k - loop_lag] if k >= loop_lag else np.zeros(3)
            force = -loop_gain * np.clip(seen, -HAND_LOOP_SATURATION, HAND_LOOP_SATURATION) \
                - HAND_LOOP_DAMPING * (v_m - target_velocity[k])
            v_m = v_m + force / HAND_LOOP_MASS * STEP
        x_m = x_m + v_m * STEP
        v_r = v_r + (stiffness * (x_d - x_r) - damping * v_r) / RESONANT_MASS * STEP
        x_r = x_r + v_r * STEP
        if k % every == 0:
            rows.append((k * STEP, *x_m, *x_d, *x_r, *target[k], *planner[k],
                         0.5 * RESONANT_MASS * float(v_r @ v_r), 0.5 * HANDLE_MASS * float(v_m @ v_m)))
    a = np.array(rows)
    time = a[:, 0]
    target_sampled, planner_sampled = a[:, 10:13], a[:, 13:16]
    command = planner_sampled + np.column_stack([np.interp(time - delay, time, target_sampled[:, j]) for j in range(3)])
    return VerdictInput(time=time, one_way_delay=delay, x_M=a[:, 1:4], x_d=a[:, 4:7], x_R=a[:, 7:10],
                        operator_target=target_sampled, planner=planner_sampled, command=command,
                        arm_kinetic_energy=a[:, 16], handle_kinetic_energy=a[:, 17], force=np.zeros((time.size, 3)),
                        contact=np.zeros(time.size, dtype=bool), limit_violations=0, reflex_trips=0, safe_holds=0,
                        stale_holds=0, source=f"resonant replica {delay:g} s, {rate_hz:g} Hz, seed {seed}",
                        quiet_from=duration if tail > 0.0 else None)


def replica_limit_cycle(data: VerdictInput, amplitude: float, period: float, phase: float = 0.7) -> VerdictInput:
    """(b) of the resonant replica: a steady oscillation of the replica alone along x, independent of the command
    (the handle and the command do not see it), with its kinetic energy."""
    w = 2.0 * math.pi / period
    swing = np.zeros_like(data.x_R)
    swing[:, 0] = amplitude * np.sin(w * data.time + phase)
    speed = amplitude * w * np.cos(w * data.time + phase)
    return replace(data, x_R=data.x_R + swing,
                   arm_kinetic_energy=data.arm_kinetic_energy + 0.5 * RESONANT_MASS * speed ** 2,
                   source=f"{data.source} + {amplitude * 1e3:g} mm at {period:.2f} s on the replica")


def cases() -> list[LabelledCase]:
    """The whole labelled set (module docstring)."""
    out: list[LabelledCase] = []
    for mass, damping, tau in ((4.0, 40.0, 0.4), (4.0, 40.0, 1.0), (4.0, 40.0, 2.0)):
        k_crit, frequency = critical_gain(mass, damping, tau)
        for factor, stable in ((0.9, True), (1.1, False)):
            data = delayed_feedback(factor * k_crit, mass, damping, tau, 60.0)
            out.append(LabelledCase(
                f"boundary tau={tau:g}s K={factor:g}Kcrit", "a delayed feedback at its boundary", stable, True, data,
                f"K_crit = {k_crit:.2f} N/m, crossing period {2 * math.pi / frequency:.2f} s (m {mass:g} kg, "
                f"D {damping:g} N s/m)"))
    references = {(delay, seed): bilateral(delay, seed) for delay in REFERENCE_DELAYS for seed in (1, 2, 3)}
    for (delay, seed), data in references.items():
        out.append(LabelledCase(f"reference delay={delay:g}s seed={seed}", "b stable reference", True, True, data,
                                "bilateral loop above the damping margin, aperiodic operator and planner"))
    for index, (delay, period, amplitude) in enumerate(
            (d, p, a) for d in CYCLE_DELAYS for p in CYCLE_PERIODS for a in CYCLE_AMPLITUDES):
        data = with_limit_cycle(references[(delay, 1 + index % 3)], amplitude, period)
        out.append(LabelledCase(f"limit cycle {amplitude * 1e3:g}mm {period:g}s delay={delay:g}s", "b limit cycle",
                                False, True, data, "steady oscillation added to a stable reference run"))
    for delay in CYCLE_DELAYS:
        circling = bilateral(delay, 7, circling=True)
        out.append(LabelledCase(f"circling reference delay={delay:g}s", "b circling task", True, True, circling,
                                "the reference loop on a task that repeats at a 4.5-5.5 s lap (its answer does too)"))
        for amplitude, period in ((0.005, 1.0), (0.010, 2.5), (0.010, 5.0), (0.020, 10.0)):
            out.append(LabelledCase(f"circling limit cycle {amplitude * 1e3:g}mm {period:g}s delay={delay:g}s",
                                    "b circling task", False, True, with_limit_cycle(circling, amplitude, period),
                                    "a steady oscillation off the lap period on the circling task"))
    _, _, peak_gain, peak_period = resonance()
    resonant = {(delay, rate, seed): resonant_plant(delay, seed, rate) for delay in RESONANT_DELAYS
                for rate in RESONANT_RATES_HZ for seed in (1, 2)}
    for (delay, rate, seed), data in resonant.items():
        out.append(LabelledCase(f"resonant replica delay={delay:g}s rate={rate:g}Hz seed={seed}",
                                "a resonant replica, forced", True, True, data,
                                f"a stable under-damped replica (gain {peak_gain:.2f} at {peak_period:.2f} s) "
                                f"answering a non-repeating command"
                                f"{' held at ' + format(rate, 'g') + ' Hz' if rate else ''}"))
    for index, (delay, rate, amplitude) in enumerate(
            (d, r, a) for d in RESONANT_DELAYS for r in RESONANT_RATES_HZ for a in CYCLE_AMPLITUDES):
        data = replica_limit_cycle(resonant[(delay, rate, 1 + index % 2)], amplitude, peak_period)
        out.append(LabelledCase(f"resonant replica + limit cycle {amplitude * 1e3:g}mm delay={delay:g}s "
                                f"rate={rate:g}Hz", "b resonant replica, limit cycle", False, True, data,
                                f"the forced replica plus a steady oscillation at its resonant period "
                                f"({peak_period:.2f} s), independent of the command"))
    for delay in RESONANT_DELAYS:
        for rate in RESONANT_RATES_HZ:
            out.append(LabelledCase(f"hand loop at 1.5 Kcrit delay={delay:g}s rate={rate:g}Hz",
                                    "c hand loop oscillating", False, True,
                                    resonant_plant(delay, 3, rate, duration=30.0 + 15.0 * delay,
                                                   hand_loop_gain=1.5),
                                    "the handle held by a hand correcting what it saw one reaction time and one "
                                    "round trip ago, above the delayed loop's K_crit: a limit cycle the command "
                                    "carries to the replica"))
    for delay in RESONANT_DELAYS:
        for rate in RESONANT_RATES_HZ:
            driven = resonant_plant(delay, 5, rate, hand_loop_gain=HAND_LOOP_STABLE)
            out.append(LabelledCase(f"reactive hand at {HAND_LOOP_STABLE:g} Kcrit delay={delay:g}s rate={rate:g}Hz",
                                    "a'' resonant replica, reactive hand", True, True, driven,
                                    "the resonant replica driven by a hand that corrects what it saw one reaction "
                                    "time and one round trip ago, below the delayed loop's K_crit: stable, its "
                                    "swing forced"))
            out.append(LabelledCase(f"reactive hand, limit cycle in the tail delay={delay:g}s rate={rate:g}Hz",
                                    "b'' resonant replica, reactive hand, limit cycle", False, True,
                                    replica_limit_cycle(driven, 0.005, peak_period),
                                    "the same loop with a 5 mm limit cycle on the replica that goes on through the "
                                    "quiet tail"))
    for stiffness in CRITICAL_DELAY_STIFFNESSES:
        critical, frequency = critical_delay(4.0, 40.0, stiffness)
        for factor, stable in ((0.9, True), (1.1, False)):
            for seed in (1, 2):
                out.append(LabelledCase(
                    f"spring-damper k={stiffness:g} T={factor:g}Tcrit seed={seed}", "d delayed spring-damper, "
                    "critical delay", stable, True, delayed_spring_damper(factor, seed, stiffness=stiffness),
                    f"T_crit = {critical:.3f} s (m 4 kg, b 40 N s/m, k {stiffness:g} N/m), crossing period "
                    f"{2 * math.pi / frequency:.2f} s"))
    for delay in (0.2, 1.0):
        base = references[(delay, 2)]
        out.append(LabelledCase(f"parked 150mm delay={delay:g}s", "c parked", False, True, parked(base),
                                "TCP 150 mm off its target from 12 s on, no contact"))
        out.append(LabelledCase(f"crash every lap delay={delay:g}s", "c crash every lap", True, False,
                                crash_every_lap(base), "30 N impacts on the avoided obstacle every 5 s"))
        out.append(LabelledCase(f"holding in contact delay={delay:g}s", "c holding in contact", True, True,
                                bilateral(delay, 4, wall=(10.0, 34.0, 0.0)),
                                "pushed into a wall from 10 to 34 s"))
        out.append(LabelledCase(f"energy pumping delay={delay:g}s", "c energy pumping", False, True,
                                pumping(references[(delay, 3)]),
                                "100 mW of steady generation at the channel's ports, motion unchanged"))
        out.append(LabelledCase(f"one collision delay={delay:g}s", "c one collision", True, True,
                                one_collision(references[(delay, 3)]),
                                f"an 80 N impact and {COLLISION_BURST_J:g} J of channel generation with it"))
        out.append(LabelledCase(f"energy pumping and a collision delay={delay:g}s", "c energy pumping", False, True,
                                pumping(one_collision(references[(delay, 3)])),
                                "100 mW of steady generation in free motion beside one collision"))
        out.append(LabelledCase(f"limit violations delay={delay:g}s", "c limit violation", True, False,
                                replace(base, limit_violations=3), "3 ticks broke a Panda limit"))
        out.append(LabelledCase(f"reflex trip delay={delay:g}s", "c reflex trip", True, False,
                                replace(base, reflex_trips=1), "the velocity reflex tripped"))
    return out


def _confusion(rows: list[dict], label: str, verdict: str) -> dict[str, int]:
    counts: dict[str, int] = {}
    for row in rows:
        judged = {True: "yes", False: "no"}.get(row[verdict], "not assessed")
        key = f"label {'yes' if row[label] else 'no'}, verdict {judged}"
        counts[key] = counts.get(key, 0) + 1
    return dict(sorted(counts.items()))


def held_out(seeds: range = range(10, 18)) -> dict:
    """The same reference loop on seeds the thresholds were not chosen on, bare (stable) and with 5 mm limit cycles
    at 0.5, 2.5, 5 and 16 s and a 10 mm one at 1 s (unstable), and the resonant replica on four of those seeds at
    each delay and rate, bare (stable) and with a 5 mm limit cycle at its resonant period (unstable): how often the
    verdict is wrong outside the set."""
    from fic_teleop_tools.verdict.run_verdict import judge

    false_alarms, misses, runs, cycles = [], [], 0, 0
    for delay in REFERENCE_DELAYS:
        for seed in seeds:
            base = bilateral(delay, seed)
            runs += 1
            if judge(base).stable is not True:
                false_alarms.append(f"delay {delay:g} s seed {seed}")
            if delay == 0.0:
                continue
            for period, amplitude in ((0.5, 0.005), (2.5, 0.005), (5.0, 0.005), (16.0, 0.005), (1.0, 0.010)):
                cycles += 1
                if judge(with_limit_cycle(base, amplitude, period)).stable is not False:
                    misses.append(f"{amplitude * 1e3:g} mm at {period:g} s, delay {delay:g} s seed {seed}")
    # The resonant replica (forced, stable) and with a 5 mm limit cycle at its resonant period (unstable).
    period = resonance()[3]
    for delay in RESONANT_DELAYS:
        for rate in RESONANT_RATES_HZ:
            for seed in seeds[:4]:
                base = resonant_plant(delay, seed, rate)
                runs += 1
                if judge(base).stable is not True:
                    false_alarms.append(f"resonant replica delay {delay:g} s rate {rate:g} Hz seed {seed}")
                cycles += 1
                if judge(replica_limit_cycle(base, 0.005, period)).stable is not False:
                    misses.append(f"5 mm at {period:.2f} s on the resonant replica, delay {delay:g} s rate {rate:g} "
                                  f"Hz seed {seed}")
    return dict(stable_runs=runs, false_alarms=false_alarms, limit_cycle_runs=cycles, missed=misses)


def validate(with_held_out: bool = True) -> dict:
    """Every labelled case judged by the run verdict, and by it without the forced-answer fit; the confusion
    matrices."""
    import time as wall_clock
    from dataclasses import asdict

    from fic_teleop_tools.verdict.forced_answer import ForcedSettings
    from fic_teleop_tools.verdict.run_verdict import VerdictCriterion, judge

    rows, seconds = [], 0.0
    # The same verdict without the forced-answer fit (the rule before it): where its blind spot was.
    without_fit = replace(VerdictCriterion(), forced=ForcedSettings(enabled=False))
    for case in cases():
        start = wall_clock.perf_counter()
        verdict = judge(case.data)
        seconds += wall_clock.perf_counter() - start
        unfitted = judge(case.data, without_fit)
        rows.append(dict(name=case.name, group=case.group, label_stable=case.stable, label_safe=case.safe,
                         stable=verdict.stable, safe=verdict.safe, right=verdict.stable is case.stable and
                         verdict.safe is case.safe, reasons=verdict.reasons, about=case.why,
                         resonance_gain=verdict.figures.get("resonance_gain"),
                         resonance_period_s=verdict.figures.get("resonance_period_s"),
                         without_fit_stable=unfitted.stable, without_fit_right=unfitted.stable is case.stable,
                         without_fit_reasons=unfitted.stable_reasons))
    groups: dict[str, dict[str, int]] = {}
    for row in rows:
        group = groups.setdefault(row["group"], dict(cases=0, right=0, without_fit_right=0))
        group["cases"] += 1
        group["right"] += row["right"]
        group["without_fit_right"] += row["without_fit_right"]
    return dict(
        command="python -m fic_teleop_experiments.verdict_cases --out results/verdict_validation.json",
        criterion=asdict(VerdictCriterion()), cases=len(rows), right=sum(r["right"] for r in rows),
        judge_seconds_per_case=round(seconds / len(rows), 3),
        confusion=dict(stable=_confusion(rows, "label_stable", "stable"), safe=_confusion(rows, "label_safe", "safe")),
        without_fit=dict(about="the run verdict without the forced-answer fit (its oscillation rule before it), "
                              "stability only", confusion_stable=_confusion(rows, "label_stable", "without_fit_stable"),
                         wrong=[r["name"] for r in rows if not r["without_fit_right"]]),
        groups=groups, held_out=held_out() if with_held_out else None, rows=rows)


def claims_comparison(cells: list[str], laws: list[str], hand: str = "reactive") -> dict:
    """The kept claim runs of ``cells`` and ``laws`` (results/claims_runs.jsonl and its series) judged by the run
    verdict with and without the forced-answer fit: what the fit changes, per cell and law, on the same runs, and
    the resonant gain the verdict found (a subset of ``claims_sweep --judge``, for a machine too busy for all)."""
    import json

    from fic_teleop_experiments.claims import load_series
    from fic_teleop_runtime.workspace import working_folder
    from fic_teleop_tools.verdict.forced_answer import ForcedSettings
    from fic_teleop_tools.verdict.run_verdict import VerdictCriterion, judge

    repo = working_folder()
    rows: dict[str, dict] = {}
    for line in (repo / "results" / "claims_runs.jsonl").read_text().splitlines():
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue
        if row.get("cell") in cells and row.get("controller") in laws and row.get("hand") == hand:
            rows[row["key"]] = row
    without_fit = replace(VerdictCriterion(), forced=ForcedSettings(enabled=False))
    out: dict[str, dict] = {}
    for _key, row in sorted(rows.items()):
        path = repo / "results" / "claims_runs" / row["series"]
        if not path.exists():
            continue
        data = VerdictInput.from_run_result(load_series(path), one_way_delay=row["delay"])
        new, old = judge(data), judge(data, without_fit)
        entry = out.setdefault(f"{row['cell']} {row['controller']}", dict(runs=0, stable_without_fit=0, stable=0,
                                                                          changed=[], resonance_gain=[],
                                                                          resonance_period_s=[]))
        entry["runs"] += 1
        entry["stable_without_fit"] += old.stable is True
        entry["stable"] += new.stable is True
        if new.stable is not old.stable:
            entry["changed"].append(dict(seed=row["seed"], without_fit=old.stable, now=new.stable,
                                         reasons=new.stable_reasons[:2]))
        entry["resonance_gain"].append(new.figures.get("resonance_gain"))
        entry["resonance_period_s"].append(new.figures.get("resonance_period_s"))
    for entry in out.values():
        gains = [g for g in entry["resonance_gain"] if g is not None]
        periods = [p for p in entry["resonance_period_s"] if p is not None]
        entry["resonance_gain_median"] = float(np.median(gains)) if gains else None
        entry["resonance_gain_quartiles"] = [float(q) for q in np.percentile(gains, [25, 75])] if gains else None
        entry["resonance_period_median_s"] = float(np.median(periods)) if periods else None
    return dict(hand=hand, cells=cells, laws=laws, by_cell_and_law=out)


def main(argv: list[str] | None = None) -> int:
    import argparse
    import json
    from pathlib import Path

    parser = argparse.ArgumentParser(prog="python -m fic_teleop_experiments.verdict_cases",
                                     description="Judge the labelled validation set; write the confusion matrices.")
    parser.add_argument("--out", type=Path, default=None, help="JSON file (default: print a summary only)")
    parser.add_argument("--no-held-out", action="store_true", help="skip the held-out seeds (about half the time)")
    parser.add_argument("--claims-cells", nargs="+", default=None, metavar="CELL",
                        help="instead: judge the kept claim runs of these cells (reactive hand) with and without the "
                             "forced-answer fit (claims_comparison) and write --out")
    parser.add_argument("--laws", nargs="+", default=["fic"], help="with --claims-cells: the laws (default fic)")
    args = parser.parse_args(argv)
    if args.claims_cells:
        result = claims_comparison(args.claims_cells, args.laws)
        for name, entry in result["by_cell_and_law"].items():
            print(f"{name}: stable {entry['stable_without_fit']}/{entry['runs']} without the fit, "
                  f"{entry['stable']}/{entry['runs']} with it; resonant gain {entry['resonance_gain_median']} at "
                  f"{entry['resonance_period_median_s']} s")
        if args.out is not None:
            args.out.write_text(json.dumps(result, indent=1) + "\n")
            print(f"wrote {args.out}")
        return 0
    result = validate(with_held_out=not args.no_held_out)
    for group, counts in result["groups"].items():
        print(f"{group:40s} {counts['right']:3d}/{counts['cases']:<3d} right (without the fit "
              f"{counts['without_fit_right']})")
    print(f"all: {result['right']}/{result['cases']}; stable {result['confusion']['stable']}; "
          f"safe {result['confusion']['safe']}")
    if result["held_out"] is not None:
        held = result["held_out"]
        print(f"held-out seeds: {len(held['false_alarms'])}/{held['stable_runs']} false alarms, "
              f"{len(held['missed'])}/{held['limit_cycle_runs']} limit cycles missed")
    if args.out is not None:
        args.out.write_text(json.dumps(result, indent=1) + "\n")
        print(f"wrote {args.out}")
    return 0 if result["right"] == result["cases"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
