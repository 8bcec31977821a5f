"""The analysis of one experiment cell from its run folder: the report's metrics, the run verdict, forces,
the shape-sorting pieces and, for E3, what happened after the link was lost."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fic_teleop_experiments.runner import Cell, report_metrics, stability_of, write_json
from fic_teleop_experiments.shape_sorting import piece_outcomes
from fic_teleop_tools.verdict.bag_series import read_run
from fic_teleop_tools.verdict.run_record import quiet_from

METRIC_KEYS = ("free_motion_error_max_m", "free_motion_error_rms_m", "contact_error_max_m", "peak_interaction_force_n",
               "limit_violations", "limit_shaped_ticks", "pipeline_latency_p50_ms", "pipeline_latency_p99_ms",
               "real_time_factor", "dropped_joint_states", "recorder_lost_messages", "recorder_lost_by_topic",
               "delay_one_way_ms", "duration_s", "controller", "energy_max_j", "master_stale_ticks")


def analyse_cell(cell: Cell, run_dir: Path, outcome, blackout_at: float | None = None) -> dict:
    requested = cell.simulated
    result = {"id": cell.id, "experiment": cell.experiment, "options": cell.options, "labels": cell.labels,
              "run_dir": str(run_dir), "launcher_exit_code": outcome.returncode, "wall_s": round(outcome.wall_s, 1),
              "simulated_s": outcome.simulated_s, "complete": outcome.simulated_s >= 0.98 * requested,
              "node_errors": outcome.node_errors}
    bag = run_dir / "bag"
    if not bag.exists():
        result["error"] = "no bag was written (see launcher.log)"
        return result
    tail_from = quiet_from(run_dir)   # the launcher's --quiet-tail (E1 and E4 cells): STABLE is judged there
    try:
        metrics = report_metrics(bag, tail_from)
        write_json(run_dir / "metrics.json", metrics)
        result["metrics"] = {key: metrics.get(key) for key in METRIC_KEYS}
    except Exception as error:  # noqa: BLE001  (a report failure is recorded, not hidden)
        result["metrics_error"] = f"{type(error).__name__}: {error}"
    series = read_run(bag)
    delay = float(cell.options["delay"])
    result["stability"] = stability_of(series, delay, quiet_from=tail_from)
    result["controller"] = series.controller
    result["limits"] = {"violation_ticks": int(series.violation_ticks[-1]) if series.violation_ticks.size else None,
                        "shaped_ticks": int(series.shaped_ticks[-1]) if series.shaped_ticks.size else None}
    robot = series.diagnostics.get("robot_sim", {})
    # Lockstep steps that went ahead on the previous torque because the replica's answer took longer than the robot's
    # lockstep_timeout (0.5 s wall, config/robot.yaml): the measure of how far a loaded machine made a lockstep run
    # non-deterministic.
    result["lockstep_timeouts"] = int(robot["lockstep_timeouts"]) if "lockstep_timeouts" in robot else None
    force = np.linalg.norm(series.force, axis=1) if series.force.size else np.zeros(0)
    result["peak_force_n"] = float(force.max()) if force.size else None
    if cell.experiment in ("E2", "E3"):
        outcomes = piece_outcomes(series)
        result["pieces"] = [o.as_dict() for o in outcomes]
        result["pieces_inside"] = sum(o.inside for o in outcomes) if outcomes else None
        robot = series.diagnostics.get("robot_sim", {})
        result["bond"] = {key: robot.get(key) for key in ("bonds_formed", "bond_breaks")}
        if force.size:
            result["force_above_10n_s"] = float(np.sum(force > 10.0) * np.median(np.diff(series.wrench_time)))
    if blackout_at is not None:
        result["blackout"] = blackout_analysis(series, blackout_at, delay)
    return result


def blackout_analysis(series, blackout_at: float, one_way_delay: float) -> dict:
    """E3: what happens after the link is lost (times in the bag's clock, sim time in lockstep)."""
    t0 = series.fic_time[0] if series.fic_time.size else 0.0
    stale = series.fic_time[series.master_stale] if series.master_stale.size else np.zeros(0)
    after = series.fic_time >= t0 + blackout_at
    out = {"blackout_at_s": blackout_at,
           "replica_holding_from_s": float(stale[0] - t0) if stale.size else None,
           "stale_share_after": float(np.mean(series.master_stale[after])) if np.any(after) else None}
    if np.any(after):
        out["energy_max_after_j"] = float(series.total_energy[after].max())
        out["energy_max_before_j"] = float(series.total_energy[~after].max()) if np.any(~after) else None
        out["energy_end_j"] = float(series.total_energy[-1])
        out["error_max_after_m"] = float(np.linalg.norm(series.error[after], axis=1).max())
    if series.limit_time.size:
        before = series.violation_ticks[series.limit_time < t0 + blackout_at]
        out["violation_ticks_after"] = int(series.violation_ticks[-1] - (before[-1] if before.size else 0))
    if series.force.size:
        force_after = np.linalg.norm(series.force[series.wrench_time >= t0 + blackout_at], axis=1)
        out["peak_force_after_n"] = float(force_after.max()) if force_after.size else None
    out["stability_after"] = stability_of(series, one_way_delay, start=t0 + blackout_at)
    return out
