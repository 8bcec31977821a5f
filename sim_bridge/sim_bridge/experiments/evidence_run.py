"""One run of an evidence cell on the in-process runner, judged by energy and motion (docs/RESULTS.md).

The seed draws the channel's jitter, the operator's timing and the hand's impedance (RunConfig); the verdict is
sim_bridge.experiments.energy_verdict's on the arm's and the handle's kinetic energy and on x_M, x_d and x_R with
the planner's commanded motion removed; errors are taken after the first 2 s (start-up).
"""
from __future__ import annotations

import numpy as np

from sim_bridge.experiments.energy_verdict import EnergyMotionCriterion, assess_energy_motion
from sim_bridge.experiments.in_process import RunConfig, run

CHANNEL_JITTER_S = 0.005         # per-message delay jitter (seeded); the paper's link is a LAN with video
OPERATOR_TIMING_JITTER_S = 0.1   # script clock shift, about half a human reaction time
HAND_IMPEDANCE_JITTER = 0.2      # +-20 % on the hand's stiffness and damping
#: The sweep's controllers: the replica's own, and the FIC as the paper writes it (Eq. 7 + posture + postural
#: optimisation, without the feedforward and friction terms: the replica's paper_law), the linear baselines, and
#: the bounded one made passive at the channel's ports by time-domain passivity (in_process: linear_tdpa).
CONTROLLERS = ("fic", "fic_paper_law", "linear", "linear_bounded", "linear_tdpa")


def judge(job: tuple[dict, str, int, float]) -> dict:
    """job: (cell {id, options: RunConfig fields}, controller, seed, duration [s]) -> one JSON-ready row."""
    cell, controller, seed, duration = job
    options = cell["options"]
    paper_law = controller == "fic_paper_law"
    config = RunConfig(duration=duration, controller="fic" if paper_law else controller, seed=seed,
                       replica_overrides={"paper_law": True} if paper_law else {}, jitter=CHANNEL_JITTER_S,
                       operator_timing_jitter=OPERATOR_TIMING_JITTER_S, hand_impedance_jitter=HAND_IMPEDANCE_JITTER,
                       **options)
    result = run(config)
    criterion = EnergyMotionCriterion(round_trip_delay=2.0 * options.get("delay", 0.2))
    # The commanded motion is removed before the motion test: the operator's script repeats its avoidance move on
    # every 5 s lap, and the scene's handle coordinates are the replica's offset (offset mode), so x_M is judged
    # against the hand's target and x_d, x_R against the planner plus that target one delay later.
    delay = options.get("delay", 0.2)
    intended = np.column_stack([np.interp(result.time - delay, result.time, result.operator_target[:, axis])
                                for axis in range(3)])
    verdict = assess_energy_motion(
        result.time, energy=result.arm_kinetic_energy + result.handle_kinetic_energy,
        motion={"x_M": result.master - result.operator_target, "x_d": result.desired - result.planner - intended,
                "x_R": result.tcp - result.planner - intended},
        criterion=criterion, error=result.desired - result.tcp, channel_generated=result.port_energy[:, 2],
        passivity_margin=result.port_energy[:, 3])
    after = result.time >= 2.0
    error = result.tracking_error[after]
    return dict(cell=cell["id"], controller=controller, seed=seed, stable=verdict.stable, assessed=verdict.assessed,
                reasons=verdict.reasons, energy_window_peaks_j=verdict.energy_window_peaks,
                energy_growth=verdict.as_dict()["energy_growth"],
                oscillation={name: dict(amplitude_m=s.amplitude, periodicity=s.periodicity, period_s=s.period)
                             for name, s in verdict.signals.items()},
                error_rms_m=float(np.sqrt(np.mean(error ** 2))), error_max_m=float(error.max()),
                peak_force_n=float(np.linalg.norm(result.force, axis=1).max()),
                limit_violations=result.limit_violations,
                passivity_margin_min_j=float(result.passivity_margin_min_j),
                passivity_violation_ticks=int(result.passivity_violation_ticks), ports=verdict.ports,
                channel_observer_min_j=dict(master=float(result.port_energy[:, 0].min()),
                                            replica=float(result.port_energy[:, 1].min())),
                offset_drift_max_m=float(result.port_energy[:, 4].max()), operator_time_shift_s=result.operator_time_shift,
                hand_scale=result.hand_scale, simulated_s=result.simulated_s, wall_s=result.wall_s,
                operator=config.operator, fixed_obstacle_contact_s=float(
                    np.sum(result.obstacle_contact[after]) * np.median(np.diff(result.time))),
                fixed_obstacle_contact_per_lap_s=contact_per_lap(result.time, result.obstacle_contact))


#: E1's laps for the contact count: 5 s each, centred on the planner's passings of the fixed obstacle (3.25 s + 5 k).
LAP_S, FIRST_LAP_START_S = 5.0, 0.75


def contact_per_lap(time: np.ndarray, contact: np.ndarray) -> list[float]:
    """Seconds of fixed-obstacle contact in each whole lap of the run."""
    step = float(np.median(np.diff(time)))
    laps = int((time[-1] - FIRST_LAP_START_S) // LAP_S)
    return [round(float(np.sum(contact[(time >= FIRST_LAP_START_S + k * LAP_S)
                                       & (time < FIRST_LAP_START_S + (k + 1) * LAP_S)]) * step), 4)
            for k in range(laps)]
