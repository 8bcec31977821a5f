"""Bag -> metrics.json + plots + a printed summary table."""
from __future__ import annotations

import json
from pathlib import Path

import yaml

from fic_teleop_runtime.workspace import config_folder

from .bag_data import BagData, load_bag
from .metrics import Analysis, ReportSettings, analyse
from .plots import plot_all

SUMMARY_KEYS = [
    ("free_motion_error_max_m", "m"), ("free_motion_error_rms_m", "m"), ("contact_error_max_m", "m"),
    ("peak_interaction_force_n", "N"), ("limit_violations", ""), ("limit_shaped_ticks", ""),
    ("pipeline_latency_p50_ms", "ms"), ("pipeline_latency_p99_ms", "ms"), ("real_time_factor", ""),
    ("dropped_joint_states", ""), ("recorder_lost_messages", ""), ("delay_one_way_ms", "ms"), ("duration_s", "s"),
    ("controller", ""),
]


def replica_config_defaults() -> dict:
    """x_b and F_max of the replica's translation FIC from config/replica.yaml, when the workspace has it."""
    path = config_folder() / "replica.yaml"
    if not path.is_file():
        return {}
    try:
        parameters = yaml.safe_load(path.read_text())["/**"]["ros__parameters"]
    except (KeyError, TypeError, yaml.YAMLError):
        return {}
    found = {}
    if "translation_max_force" in parameters:
        found["max_force_n"] = float(parameters["translation_max_force"])
    if "translation_saturation_error" in parameters:
        found["error_bound_m"] = float(parameters["translation_saturation_error"])
    return found


def make_report(bag: str | Path, out: str | Path, settings: ReportSettings | None = None, *,
                key_frame_interval: float | None = None, scene: str = "superimposition",
                data: BagData | None = None) -> tuple[Analysis, list[Path]]:
    """Read `bag` (or take `data`, the bag as load_bag read it with the same `key_frame_interval`), write
    `out`/metrics.json and the PNG plots (and key frames every `key_frame_interval` s of sim time, when given);
    returns the analysis and the image paths."""
    settings = settings or ReportSettings()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    data = data if data is not None else load_bag(bag, keyframe_interval=key_frame_interval)
    analysis = analyse(data, settings)
    plots = plot_all(data, analysis, settings, out)
    if key_frame_interval:
        from .key_frames import render_key_frames

        plots += render_key_frames(data, out, scene)
    analysis.metrics["plots"] = [p.name for p in plots]
    (out / "metrics.json").write_text(json.dumps(analysis.metrics, indent=2) + "\n")
    return analysis, plots


def _format(value, unit: str) -> str:
    if value is None:
        return "n/a"
    if isinstance(value, float):
        return f"{value:.4g} {unit}".strip()
    return f"{value} {unit}".strip()


def summary_table(metrics: dict) -> str:
    rows = []
    for key, unit in SUMMARY_KEYS:
        target = metrics.get("targets", {}).get(key)     # as this run's report judged it (its own bound)
        check = ""
        if target:
            met = target.get("met")
            check = f"{target['target']}  " + ("ok" if met else ("n/a" if met is None else "MISSED"))
        rows.append((key, _format(metrics.get(key), unit), check))
    width = max(len(r[0]) for r in rows)
    value_width = max(len(r[1]) for r in rows)
    lines = [f"{'metric':<{width}}  {'value':>{value_width}}  target", "-" * (width + value_width + 24)]
    lines += [f"{k:<{width}}  {v:>{value_width}}  {c}" for k, v, c in rows]
    lines += [f"n/a {key}: {reason}" for key, reason in (metrics.get("not_measured") or {}).items()]
    return "\n".join(lines)
