"""The experiments' summaries from their result files (eN.json): the headline numbers and the markdown tables that
docs/EXPERIMENTS.md is drafted from."""
from __future__ import annotations

import json
from pathlib import Path


def _number(value, digits: int = 3, scale: float = 1.0) -> str:
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, float)):
        return f"{value * scale:.{digits}f}"
    return str(value)


def markdown_tables(results_dir: Path) -> str:
    """Markdown tables of whatever eN.json the results folder holds (docs/EXPERIMENTS.md is drafted from them)."""
    lines: list[str] = []
    path = results_dir / "e1.json"
    if path.exists():
        e1 = json.loads(path.read_text())
        m = e1.get("metrics", {})
        s = e1.get("stability", {})
        lines += ["### E1 superimposition, 200 ms each way (" + e1.get("time_mode", "") + ")", "",
                  "| metric | value |", "|---|---|"]
        for key, unit, scale in (("free_motion_error_max_m", "mm", 1e3), ("free_motion_error_rms_m", "mm", 1e3),
                                 ("contact_error_max_m", "mm", 1e3), ("peak_interaction_force_n", "N", 1.0),
                                 ("limit_violations", "", 1.0), ("limit_shaped_ticks", "", 1.0),
                                 ("pipeline_latency_p50_ms", "ms", 1.0), ("pipeline_latency_p99_ms", "ms", 1.0),
                                 ("real_time_factor", "", 1.0), ("dropped_joint_states", "", 1.0),
                                 ("duration_s", "s", 1.0)):
            value = m.get(key)
            digits = 0 if key in ("limit_violations", "limit_shaped_ticks", "dropped_joint_states") else 2
            lines.append(f"| {key} | {_number(value, digits, scale)} {unit} |")
        lines += [f"| stable (criterion) | {_number(s.get('stable'))} {'; '.join(s.get('reasons') or [])} |", ""]
    path = results_dir / "e2.json"
    if path.exists():
        e2 = json.loads(path.read_text())
        lines += ["### E2 shape sorting (" + e2.get("time_mode", "") + ")", "",
                  "| trial (seed) | pieces inside the box | bonds formed / broken | peak force [N] | time above 10 N [s] "
                  "| limit violations | stable |", "|---|---|---|---|---|---|---|"]
        for trial in e2["trials"]:
            bond = trial.get("bond", {})
            names = ", ".join(p["name"].replace("piece_", "") for p in trial.get("pieces", []) if p["inside"]) or "none"
            lines.append(f"| {trial['labels'].get('seed')} | {trial.get('pieces_inside')} / 3 ({names}) | "
                         f"{bond.get('bonds_formed')} / {bond.get('bond_breaks')} | {_number(trial.get('peak_force_n'), 1)} | "
                         f"{_number(trial.get('force_above_10n_s'), 2)} | {trial.get('limits', {}).get('violation_ticks')} | "
                         f"{_number(trial.get('stability', {}).get('stable'))} |")
        lines += ["", f"Trials with all three pieces inside: {e2['successful_trials']} of {len(e2['trials'])}; pieces "
                  f"inside: {e2['pieces_inside_total']} of {3 * len(e2['trials'])}; replica F_max = "
                  f"{_number(e2.get('replica_max_force_n'), 0)} N.", ""]
    path = results_dir / "e3.json"
    if path.exists():
        e3 = json.loads(path.read_text())
        b = e3.get("blackout", {})
        st = b.get("stability_after", {})
        lines += ["### E3 blackout during contact (" + e3.get("time_mode", "") + ")", "", "| quantity | value |",
                  "|---|---|",
                  f"| link lost from | {_number(b.get('blackout_at_s'), 1)} s |",
                  f"| replica holding x_d' from (watchdog) | {_number(b.get('replica_holding_from_s'), 2)} s |",
                  f"| energy max before / after the loss | {_number(b.get('energy_max_before_j'), 3)} / "
                  f"{_number(b.get('energy_max_after_j'), 3)} J |",
                  f"| energy at the end | {_number(b.get('energy_end_j'), 3)} J |",
                  f"| limit-violation ticks after the loss | {b.get('violation_ticks_after')} |",
                  f"| peak force after the loss | {_number(b.get('peak_force_after_n'), 1)} N |",
                  f"| max error after the loss | {_number(b.get('error_max_after_m'), 1, 1e3)} mm |",
                  f"| stable after the loss (criterion on [loss, end]) | {_number(st.get('stable'))} "
                  f"{'; '.join(st.get('reasons') or [])} |", ""]
    path = results_dir / "e4.json"
    if path.exists():
        e4 = json.loads(path.read_text())
        lines += ["### E4 sweeps (" + e4.get("time_mode", "") + ", " +
                  _number(e4["cells"][0]["options"]["duration"] if e4.get("cells") else None, 0) + " s a cell)", "",
                  "| sweep | one-way delay [s] | rate [Hz] | controller | stable | max error, last half [mm] | "
                  "max error [mm] | limit violations | shaped ticks | peak force [N] | why not stable |",
                  "|---|---|---|---|---|---|---|---|---|---|---|"]
        for row in e4["table"]:
            lines.append(f"| {row['sweep']} | {row['delay']:g} | {row['rate']:g} | {row['controller']} | "
                         f"{_number(row['stable'])} | {_number(row['max_error_last_half_m'], 1, 1e3)} | "
                         f"{_number(row['max_error_m'], 1, 1e3)} | {row['violation_ticks']} | {row['shaped_ticks']} | "
                         f"{_number(row['peak_force_n'], 0)} | {'; '.join(row.get('reasons') or []) or '-'}"
                         + ("" if row.get("complete", True) else " (run cut short)") + " |")
        lines.append("")
    return "\n".join(lines)


def headline_of(name: str, data: dict) -> dict:
    """The few numbers of an experiment that the summary shows (from its eN.json)."""
    if name == "E1":
        return {"stable": data.get("stability", {}).get("stable"), **{
            key: data.get("metrics", {}).get(key) for key in (
                "free_motion_error_max_m", "free_motion_error_rms_m", "contact_error_max_m",
                "peak_interaction_force_n", "limit_violations", "limit_shaped_ticks")}}
    if name == "E2":
        return {key: data.get(key) for key in ("pieces_inside_per_trial", "successful_trials", "peak_force_n_max",
                                               "replica_max_force_n", "stable_trials", "violation_ticks_total")}
    if name == "E3":
        blackout = data.get("blackout", {})
        return {**{key: blackout.get(key) for key in ("blackout_at_s", "energy_max_before_j", "energy_max_after_j",
                                                      "violation_ticks_after", "peak_force_after_n")},
                "stable_after": blackout.get("stability_after", {}).get("stable")}
    if name == "E4":
        return {row["id"]: {"stable": row["stable"], "max_error_last_half_m": row["max_error_last_half_m"],
                            "violation_ticks": row["violation_ticks"]} for row in data.get("table", [])}
    return {}
