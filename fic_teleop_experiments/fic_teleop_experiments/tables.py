"""The experiments' summaries from their result files (eN.json): the headline numbers and the markdown tables that
docs/EXPERIMENTS.md is drafted from."""
from __future__ import annotations

import json
from pathlib import Path

from fic_teleop_experiments.unstable_tests import UNSTABLE_TESTS


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
                  "| trial (seed) | pieces inside the box | bonds formed / broken | peak force [N] | time above 10 N "
                  "[s] "
                  "| limit violations | stable |", "|---|---|---|---|---|---|---|"]
        for trial in e2["trials"]:
            bond = trial.get("bond", {})
            names = ", ".join(p["name"].replace("piece_", "") for p in trial.get("pieces", []) if p["inside"]) or "none"
            lines.append(f"| {trial['labels'].get('seed')} | {trial.get('pieces_inside')} / 3 ({names}) | "
                         f"{bond.get('bonds_formed')} / {bond.get('bond_breaks')} | "
                         f"{_number(trial.get('peak_force_n'), 1)} | "
                         f"{_number(trial.get('force_above_10n_s'), 2)} | "
                         f"{trial.get('limits', {}).get('violation_ticks')} | "
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


def _share(share: dict) -> tuple[str, str]:
    interval = share.get("interval_95")
    return (f"{share['k']}/{share['n']}",
            "-" if interval is None else f"{interval[0]:.2f}-{interval[1]:.2f}")


def _pair(median, p95, scale: float, digits: int) -> str:
    return "-" if median is None else f"{median * scale:.{digits}f} / {p95 * scale:.{digits}f}"


def _p(value) -> str:
    return "-" if value is None else (f"{value:.3f}" if value >= 0.001 else f"{value:.1e}")


def _cell_label(row: dict) -> str:
    return " ".join(str(row[name]) for name in ("cell", "operator", "hand") if row.get(name) is not None)


def claims_markdown(document: dict) -> str:
    """The claim sweep's tables (results/claims_tables.md; docs/EXPERIMENTS.md "Claims" pastes them): per cell and
    law both verdicts' k/n with Wilson intervals, the swing and the tracking error beside the stable share, and the
    error and force figures; the FIC against each baseline."""
    planned = document.get("seeds_planned")
    source = document.get("source", "the sweep")
    lines = [f"Runs: {document['runs_judged']} judged of {document['runs_total']} in {source}"
             + (f"; {planned} seeds a cell and law planned" if planned else "") + ".", "",
             "| cell | law | runs judged | stable k/n | Wilson 95 % | swing median / p95 [mm] "
             "| error RMS median / p95 [mm] | safe k/n | Wilson 95 % "
             "| error max median / p95 [mm] | peak force median / p95 [N] |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for cell in document["cells"]:
        for law, s in cell["laws"].items():
            stable, stable_interval = _share(s["stable"])
            if s["judged"] > s["stable"]["n"]:   # runs too short for the periods the stable verdict must see
                stable += f" ({s['judged'] - s['stable']['n']} not assessed)"
            safe, safe_interval = _share(s["safe"])
            seeds = f"{s['judged']}" + ("" if s["judged"] == s["runs"] else f" ({s['runs']} run)")
            lines.append(f"| {_cell_label(cell)} | {law} | {seeds} | {stable} | {stable_interval} | "
                         f"{_pair(s.get('swing_median'), s.get('swing_p95'), 1e3, 1)} | "
                         f"{_pair(s['error_rms_median'], s['error_rms_p95'], 1e3, 1)} | {safe} | {safe_interval} | "
                         f"{_pair(s['error_max_median'], s['error_max_p95'], 1e3, 1)} | "
                         f"{_pair(s['peak_force_median'], s['peak_force_p95'], 1.0, 1)} |")
    lines += ["", "Which stable test each law's unstable runs failed (a run may fail several; "
              "fic_teleop_tools/verdict/run_verdict.py):", "",
              "| cell | law | not stable | " + " | ".join(UNSTABLE_TESTS) + " |",
              "|---|---|---|" + "---|" * len(UNSTABLE_TESTS)]
    for cell in document["cells"]:
        for law, s in cell["laws"].items():
            failed = s.get("unstable_by_test")
            if failed is None:
                continue
            lines.append(f"| {_cell_label(cell)} | {law} | {s['stable']['n'] - s['stable']['k']} | "
                         + " | ".join(str(failed[test]) for test in UNSTABLE_TESTS) + " |")
    reference = document.get("reference_law", "fic")
    lines += ["", f"{reference} against each baseline: difference of the shares (reference minus baseline) with "
              "Newcombe's 95 % interval; Boschloo's exact test, two-sided (Fisher's beside it).", "",
              f"| cell | baseline | verdict | {reference} k/n | baseline k/n | difference | Newcombe 95 % | Boschloo p "
              "| Fisher p |", "|---|---|---|---|---|---|---|---|---|"]
    for comparison in document["comparisons"]:
        for verdict in ("stable", "safe"):
            c = comparison[verdict]
            interval = c["difference_interval_95"]
            lines.append(f"| {_cell_label(comparison)} | {comparison['baseline']} | {verdict} | "
                         f"{c['reference_k_n'][0]}/{c['reference_k_n'][1]} | "
                         f"{c['baseline_k_n'][0]}/{c['baseline_k_n'][1]} | "
                         + ("-" if c["difference"] is None else f"{c['difference']:+.2f}") + " | "
                         + ("-" if interval is None else f"{interval[0]:+.2f} to {interval[1]:+.2f}") + " | "
                         f"{_p(c['boschloo_p'])} | {_p(c['fisher_p'])} |")
    return "\n".join(lines) + "\n"


#: The claim cells of docs/RESULTS.md's claims block, each with the literature's meaning (docs/EXPERIMENTS.md
#: "Claims"): the FIC papers' "extreme delays up to 1 s" and "communication bandwidths as low as 10 Hz", the law and
#: the robot at 1 kHz in every cell.
RESULTS_CLAIM_CELLS = (
    ("delay_1__rate_full", "1 s one-way delay, link at full rate"),
    ("delay_1__rate_10", "1 s one-way delay and the link at 10 Hz both ways, together"),
    ("delay_0.2__rate_10", "the link at 10 Hz both ways, the paper's 0.2 s delay"),
)
#: The open-loop controls the claims block reads beside the claims (fic_teleop_experiments.claims CONTROL_CELLS): the
#: same runs with the force feedback off, where no force loop closes through the channel. Not a claim: what they show
#: is how much of a claim cell's instability the closed loop adds.
RESULTS_CONTROL_CELLS = (
    ("delay_1__rate_10__feedback_off",
     "control: 1 s and 10 Hz, the force feedback off (no force loop through the channel)"),
    ("delay_0.2__rate_10__feedback_off", "control: 0.2 s and 10 Hz, the force feedback off"),
)
CONTROL_READING = "control, not a claim"
#: A claim of stability is read as "stable in nearly every run": reproduced when the FIC's stable share has a Wilson
#: 95 % lower bound of at least this (at 20 seeds: 19 or 20 of 20), not reproduced when the upper bound is below
#: it, undecided in between (too few runs, or a share near it).
REPRODUCED_SHARE = 0.75


def claim_reading(share: dict, threshold: float = REPRODUCED_SHARE) -> str:
    """'reproduced', 'not reproduced' or 'undecided at n = N' for a stable share {k, n, interval_95}."""
    if not share or not share.get("n"):
        return "no run judged yet"
    low, high = share["interval_95"]
    if low >= threshold:
        return "reproduced"
    if high < threshold:
        return "not reproduced"
    return f"undecided at n = {share['n']}"


def claims_block(statistics: dict, reference: str = "fic") -> str:
    """docs/RESULTS.md's block on the FIC papers' claims, every figure from results/claims_statistics.json
    (test/experiments/test_readme_results.py regenerates it and compares). One row per claim cell and hand; a cell
    without runs says so."""
    planned = statistics.get("seeds_planned")
    cells = {(c["cell"], c.get("hand")): c for c in statistics.get("cells", [])}
    hands = sorted({c.get("hand") for c in statistics.get("cells", [])}, key=str) or [None]
    comparisons = {(c["cell"], c.get("hand"), c["baseline"]): c for c in statistics.get("comparisons", [])}
    judged_n = [s["stable"]["n"] for c in statistics.get("cells", []) for s in c["laws"].values()]
    # Every law, cell and hand at its planned seeds: the sweep is complete and nothing is "so far" any more.
    complete = (bool(judged_n) and planned is not None and min(judged_n) >= planned
                and all((cell_id, hand) in cells for cell_id, _ in RESULTS_CLAIM_CELLS for hand in hands))
    # The claim rows alone at their planned seeds (or more): the sweep runs the claim cells first, so their figures
    # are final while its other cells (the open-loop controls, 2 s, the delay sweep's extra delays) still run.
    rows_complete = planned is not None and all(
        (cell_id, hand) in cells and cells[(cell_id, hand)]["laws"]
        and min(s["stable"]["n"] for s in cells[(cell_id, hand)]["laws"].values()) >= planned
        for cell_id, _ in RESULTS_CLAIM_CELLS for hand in hands)
    if complete:
        opening = (f"All {statistics.get('runs_judged', 0)} runs of the claim sweep judged ({planned} seeds a law, "
                   "cell and hand)")
    elif rows_complete:
        opening = (f"The claim rows are complete ({planned} seeds or more a law, cell and hand); "
                   f"{statistics.get('runs_judged', 0)} runs of the claim sweep judged so far, its other cells (the "
                   "open-loop controls, 2 s and the delay sweep's extra delays) still running")
    else:
        opening = (f"Judged so far: {statistics.get('runs_judged', 0)} runs of the claim sweep"
                   + (f" ({min(judged_n)}-{max(judged_n)} judged seeds a law, cell and hand, of {planned} planned)"
                      if judged_n else "") + "; the sweep resumes where it stopped")
    lines = [opening + ". A claim is read as reproduced when "
             f"the FIC's stable share has a Wilson 95 % lower bound of at least {REPRODUCED_SHARE:.2f}, not "
             "reproduced when the upper bound is below it, undecided otherwise.", "",
             f"| claim, as the literature means it | hand | {reference} stable | {reference} safe | baselines stable "
             f"| {reference} minus baseline, stable share (Newcombe 95 %; Boschloo p) | reading |",
             "|---|---|---|---|---|---|---|"]

    def share_text(share: dict | None) -> str:
        if not share or not share["n"]:
            return "-"
        low, high = share["interval_95"]
        return f"{share['k']}/{share['n']} ({low:.2f}-{high:.2f})"

    def motion_text(law_statistics: dict) -> str:
        """The law's median swing and RMS tracking error beside its stable share, when the verdict reported a
        swing (statistics judged before it have none, and their block reads as it did)."""
        if law_statistics.get("swing_median") is None:
            return ""
        error = law_statistics.get("error_rms_median")
        return (f"; swing {law_statistics['swing_median'] * 1e3:.0f} mm"
                + ("" if error is None else f", error {error * 1e3:.0f} mm"))

    readings: list[str] = []
    controls = [(cell_id, meaning, True) for cell_id, meaning in RESULTS_CONTROL_CELLS
                if any(key[0] == cell_id for key in cells)]
    for cell_id, meaning, control in [(c, m, False) for c, m in RESULTS_CLAIM_CELLS] + controls:
        for hand in hands:
            cell = cells.get((cell_id, hand))
            if control and cell is None:
                continue
            laws = cell["laws"] if cell else {}
            ours = laws.get(reference, {})
            baselines = ", ".join(f"{law} {s['stable']['k']}/{s['stable']['n']}{motion_text(s)}"
                                  for law, s in laws.items() if law != reference and s["stable"]["n"]) or "-"
            differences = []
            for law in laws:
                comparison = comparisons.get((cell_id, hand, law), {}).get("stable")
                if law == reference or not comparison or comparison["difference"] is None:
                    continue
                low, high = comparison["difference_interval_95"]
                differences.append(f"{law} {comparison['difference']:+.2f} ({low:+.2f} to {high:+.2f}; "
                                   f"p {_p(comparison['boschloo_p'])})")
            reading = CONTROL_READING if control else claim_reading(ours.get("stable"))
            if not control:
                readings.append(reading)
            lines.append(f"| {meaning} (`{cell_id}`) | {hand or '-'} | {share_text(ours.get('stable'))}"
                         f"{motion_text(ours)} | "
                         f"{share_text(ours.get('safe'))} | {baselines} | {'; '.join(differences) or '-'} | "
                         f"{reading} |")
    tally = {name: sum(1 for r in readings if r.startswith(name)) for name in ("reproduced", "not reproduced",
                                                                                 "undecided", "no run")}
    lines += ["", f"Of these {len(readings)} claim rows: {tally['reproduced']} reproduced, {tally['not reproduced']} "
              f"not reproduced, {tally['undecided']} undecided "
              + (f"at {planned} seeds." if complete else "at the seeds of each row." if rows_complete else
                 f"at the seeds judged so far, {tally['no run']} without a judged run yet.")]
    lines += _control_sentences(cells, controls, hands, reference)
    lines += _resonance_sentences(cells, controls, hands)
    return "\n".join(lines) + "\n"


def _resonance_sentences(cells: dict, controls: list, hands: list) -> list[str]:
    """For each open-loop control with runs: every law's resonant amplification as the verdict found it (the
    median over the judged runs of the peak gain of x_R to the operator's planned target, at the median period)."""
    out = []
    for cell_id, _, _ in controls:
        for hand in hands:
            cell = cells.get((cell_id, hand))
            laws = [(law, s) for law, s in (cell["laws"].items() if cell else ())
                    if s.get("resonance_gain_median") is not None]
            if not laws:
                continue
            text = "; ".join(f"{law} {s['resonance_gain_median']:.2f} at {s['resonance_period_median_s']:.2f} s"
                             for law, s in laws)
            out += ["", f"Resonant amplification the verdict found on `{cell_id}` ({hand} hand; the peak gain of x_R "
                        f"to the operator's planned target, median over the judged runs, at the median period): "
                        f"{text}."]
    return out


def _control_sentences(cells: dict, controls: list, hands: list, reference: str) -> list[str]:
    """For each open-loop control with runs: every law's stable k/n with the force loop (its claim cell) and
    without it, and for the reference law the difference (with minus without) with Newcombe's interval and
    Boschloo's p: how much of a claim cell's instability the closed force loop adds."""
    from fic_teleop_experiments.cell_statistics import boschloo_p, newcombe_difference_interval

    out = []
    for cell_id, _, _ in controls:
        claim_id = cell_id.removesuffix("__feedback_off")
        for hand in hands:
            closed, open_ = cells.get((claim_id, hand)), cells.get((cell_id, hand))
            if not closed or not open_:
                continue
            shares = []
            for law, without in open_["laws"].items():
                with_loop = closed["laws"].get(law, {}).get("stable")
                if with_loop and with_loop["n"] and without["stable"]["n"]:
                    shares.append((law, with_loop, without["stable"]))
            if not shares:
                continue
            text = "; ".join(f"{law} {w['k']}/{w['n']} with, {o['k']}/{o['n']} without" for law, w, o in shares)
            sentence = (f"Open-loop control of `{claim_id}` ({hand} hand), stable with the force loop and without it "
                        f"(K_H = 0, `{cell_id}`): {text}.")
            ours = next(((w, o) for law, w, o in shares if law == reference), None)
            if ours:
                (w, o) = ours
                difference, low, high = newcombe_difference_interval(w["k"], w["n"], o["k"], o["n"])
                sentence += (f" {reference}, with minus without: {difference:+.2f} ({low:+.2f} to {high:+.2f}; "
                             f"p {_p(boschloo_p(w['k'], w['n'], o['k'], o['n']))}).")
            out += ["", sentence]
    return out
