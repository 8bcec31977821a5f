"""One run of an evidence cell on the in-process runner, judged by energy and motion (docs/EXPERIMENTS.md).

The seed draws the channel's jitter, the operator's timing and the hand's impedance (RunConfig); the verdict is
fic_teleop_experiments.energy_verdict's on the arm's and the handle's kinetic energy, the channel's generated
energy, and on x_M, x_d and x_R with the commanded motion and the lap's typical (median) motion removed; errors are taken after
the first 2 s (start-up). A run's time series can be kept (``save_series``) and judged again without simulating it.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fic_teleop_experiments.energy_verdict import EnergyMotionCriterion, assess_energy_motion
from fic_teleop_experiments.in_process import RunConfig, RunResult, run

CHANNEL_JITTER_S = 0.005         # per-message delay jitter (seeded); the paper's link is a LAN with video
OPERATOR_TIMING_JITTER_S = 0.1   # script clock shift, about half a human reaction time
HAND_IMPEDANCE_JITTER = 0.2      # +-20 % on the hand's stiffness and damping
#: E1's lap: the planner's circle and the operator's script repeat every 5 s (the verdict's task_period); the laps of
#: the contact count are centred on the planner's passings of the fixed obstacle (3.25 s + 5 k).
LAP_S, FIRST_LAP_START_S = 5.0, 0.75
#: The sweep's controllers: the replica's own, and the FIC as the paper writes it (Eq. 7 + posture + postural
#: optimisation, without the feedforward and friction terms: the replica's paper_law), the linear baselines, and
#: the bounded one made passive at the channel's ports by time-domain passivity (in_process: linear_tdpa).
CONTROLLERS = ("fic", "fic_paper_law", "linear", "linear_bounded", "linear_tdpa")


def run_config(cell: dict, controller: str, seed: int, duration: float) -> RunConfig:
    """The runner's configuration of one run of a cell (the seed's jitters, the paper_law override)."""
    paper_law = controller == "fic_paper_law"
    return RunConfig(duration=duration, controller="fic" if paper_law else controller, seed=seed,
                     replica_overrides={"paper_law": True} if paper_law else {}, jitter=CHANNEL_JITTER_S,
                     operator_timing_jitter=OPERATOR_TIMING_JITTER_S, hand_impedance_jitter=HAND_IMPEDANCE_JITTER,
                     **cell["options"])


#: The RunResult fields the verdict and the row read; a run's series file keeps them (and nothing of the scene), so
#: a changed criterion can re-judge a sweep without simulating it again.
SERIES_FIELDS = ("time", "desired", "tcp", "force", "offset", "master", "planner", "arm_kinetic_energy",
                 "handle_kinetic_energy", "operator_target", "port_energy", "obstacle_contact")
SERIES_SCALARS = ("wall_s", "simulated_s", "limit_violations", "shaped_ticks", "operator_time_shift", "hand_scale",
                  "passivity_margin_min_j", "passivity_violation_ticks")


def series_path(directory: Path, cell: dict, controller: str, seed: int, duration: float) -> Path:
    return Path(directory) / f"{cell['id']}__{controller}__{seed}__{duration:g}s.npz"


def save_series(path: Path, result: RunResult) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **{name: getattr(result, name) for name in SERIES_FIELDS},
                        **{name: np.asarray(getattr(result, name)) for name in SERIES_SCALARS})


def load_series(path: Path) -> RunResult:
    with np.load(path) as data:
        arrays = {name: data[name] for name in SERIES_FIELDS}
        scalars = {name: data[name].item() for name in SERIES_SCALARS}
    return RunResult(objects={}, **arrays, **scalars)


def judge(job: tuple) -> dict:
    """job: (cell {id, options: RunConfig fields}, controller, seed, duration [s][, series directory[, reuse]]) ->
    one JSON-ready row. With a series directory the run's time series are written there (``save_series``); with
    reuse True as well, a run already there is judged from its file instead of being simulated again."""
    cell, controller, seed, duration = job[:4]
    directory = job[4] if len(job) > 4 else None
    reuse = bool(job[5]) if len(job) > 5 else False
    config = run_config(cell, controller, seed, duration)
    path = series_path(directory, cell, controller, seed, duration) if directory is not None else None
    reused = path is not None and reuse and path.exists()
    if reused:
        result = load_series(path)
    else:
        result = run(config)
        if path is not None:
            save_series(path, result)
    # wall_s stays the simulation's own (kept in the file); from_series says this row did not simulate it now.
    return {**row(cell, controller, seed, config, result), "from_series": reused}


def row(cell: dict, controller: str, seed: int, config: RunConfig, result: RunResult) -> dict:
    """The verdict of one run and the figures the sweep's tables carry."""
    options = cell["options"]
    # The commanded motion is removed before the motion test: the operator's script repeats its avoidance move on
    # every 5 s lap, and the scene's handle coordinates are the replica's offset (offset mode), so x_M is judged
    # against the hand's target and x_d, x_R against the planner plus that target one delay later. What the loop
    # does in answer to that command (the hand giving way to the force it feels, the replica lagging) repeats at
    # the lap when the loop is stable: the verdict removes the lap's typical (median) motion too (task_period, lap_median.py).
    criterion = EnergyMotionCriterion(round_trip_delay=2.0 * options.get("delay", 0.2), task_period=LAP_S)
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
                energy_growth=verdict.as_dict()["energy_growth"], windows_overlap_s=verdict.windows_overlap,
                motion_judged_from_s=verdict.as_dict()["motion_judged_from"],
                max_period_judged_s=verdict.max_period_judged, laps_in_lap_median=verdict.laps_in_lap_median,
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


def contact_per_lap(time: np.ndarray, contact: np.ndarray) -> list[float]:
    """Seconds of fixed-obstacle contact in each whole lap of the run."""
    step = float(np.median(np.diff(time)))
    laps = int((time[-1] - FIRST_LAP_START_S) // LAP_S)
    return [round(float(np.sum(contact[(time >= FIRST_LAP_START_S + k * LAP_S)
                                       & (time < FIRST_LAP_START_S + (k + 1) * LAP_S)]) * step), 4)
            for k in range(laps)]
