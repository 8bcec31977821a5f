"""The figures of docs/RESULTS.md and of README's results table against the results/ files they come from: a table
of checks, one row a figure (or a group of figures in one table cell). Each row finds its text in its document
(whitespace-normalised, exactly once) and compares every captured figure with the file, formatted as the document
writes it. A new figure from results/ in either document gets a row here."""
from __future__ import annotations

import json
import re
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Callable

import pytest

from fic_teleop_experiments.cell_statistics import wilson_interval
from fic_teleop_experiments.shape_sorting import PIECE_NAMES

REPO = Path(__file__).resolve().parents[2]


@cache
def result(name: str) -> dict:
    return json.loads((REPO / "results" / name).read_text())


def jsonl(name: str) -> list[dict]:
    """The rows of a results/ jsonl (one finished trial a line)."""
    return [json.loads(line) for line in (REPO / "results" / name).read_text().splitlines() if line.strip()]


def complete(trial: dict) -> bool:
    """An E2 trial is complete when every piece ended inside the box (as the E2 sweep's summary counts it)."""
    return len(trial["pieces_inside"]) == len(PIECE_NAMES)


def interval(k: int, n: int) -> dict:
    low, high = wilson_interval(k, n)
    return dict(low=f"{low:.2f}", high=f"{high:.2f}")


def complete_of(trials: list[dict], law: str, delay: float, seeds: int) -> tuple[int, int]:
    """(trials complete, trials) of one sweep cell over its seeds 1..``seeds`` (a seed counted once)."""
    kept = {t["seed"]: t for t in trials if t["law"] == law and t["delay_s"] == delay and t["seed"] <= seeds}
    return sum(complete(t) for t in kept.values()), len(kept)


def e2_sweep_at_200ms() -> dict:
    """The in-process sweep may keep appending trials (seed-major), so RESULTS.md states k of n for its
    first n seeds a law: each k is recomputed from results/e2_sweep.jsonl's trials of seeds 1..n, and the FIC's
    interval from them."""
    said = re.search(r"at 200 ms: the default FIC \d+ of (?P<fic>\d+) .*?as written \d+ of (?P<fic_paper_law>\d+) .*?"
                     r"linear \d+ of (?P<linear>\d+), linear_bounded \d+ of (?P<linear_bounded>\d+), "
                     r"linear_tdpa \d+ of (?P<linear_tdpa>\d+)", results_page())
    if said is None:
        return {}
    trials = jsonl("e2_sweep.jsonl")
    expected = {}
    for law, n in said.groupdict().items():
        k, count = complete_of(trials, law, 0.2, int(n))
        expected[law] = f"{k} of {count}"
        if law == "fic":
            expected.update(interval(k, count))
    return expected


def e2_sweep_other_delays() -> dict:
    """The trials complete at 0, 0.5 and 1 s for every law, from results/e2_sweep.jsonl's seeds 1..10."""
    trials = jsonl("e2_sweep.jsonl")
    expected = {}
    for law in ("fic", "fic_paper_law", "linear", "linear_bounded", "linear_tdpa"):
        counts = [complete_of(trials, law, delay, 10)[0] for delay in (0.0, 0.5, 1.0)]
        expected[law] = f"{counts[0]}, {counts[1]} and {counts[2]}"
    return expected


def graph_trials(file: str, said: str) -> dict:
    """k of n for a law on the graph: its first n trials in the jsonl (n as RESULTS.md says it), so that a trial
    appended later does not change the figure; with its Wilson interval."""
    found = re.search(said, results_page())
    trials = jsonl(file)[:int(found.group("trials"))] if found else []
    k = sum(complete(t) for t in trials)
    return dict(complete=str(k), trials=str(len(trials)), **(interval(k, len(trials)) if trials else {}))


CLAIMS_BEGIN, CLAIMS_END = "<!-- claims: begin", "<!-- claims: end -->"


def normalised(text: str) -> str:
    return " ".join(text.split())


@cache
def results_page() -> str:
    """docs/RESULTS.md without its generated claims block (test_claims_block_is_generated_from_the_statistics checks
    that one to the character)."""
    text = (REPO / "docs" / "RESULTS.md").read_text()
    if CLAIMS_BEGIN in text:
        text = text[:text.index(CLAIMS_BEGIN)] + text[text.index(CLAIMS_END):]
    return normalised(text)


@cache
def readme_results() -> str:
    """README's "Results" section: its short table of headline figures."""
    text = (REPO / "README.md").read_text()
    section = text[text.index("## Results"):]
    return normalised(section[:section.index("\n## ", 1)])


DOCUMENTS = {"RESULTS": results_page, "README": readme_results}


def one_count_of(values) -> str:
    """One figure for several laws, cells or baselines: it must be the same for all of them."""
    found = set(values)
    return found.pop() if len(found) == 1 else f"differs: {sorted(found)}"


def mm(metres: float) -> str:
    return f"{metres * 1e3:.1f}"


@dataclass(frozen=True)
class Figure:
    name: str
    where: str                                    # "RESULTS" (docs/RESULTS.md) or "README" (its results table)
    pattern: str                                  # regex on that document, named groups = figures
    expected: Callable[[], dict[str, str]]        # the same names, from results/, as the document writes them


BASELINES = ("fic_paper_law", "linear", "linear_bounded", "linear_tdpa")


def bench_runs(name: str) -> list[float]:
    return [run[name] for run in result("bench.json")["default_runs"]]


def bench_range(name: str) -> tuple[float, float]:
    """(min, max) over the ten default runs of a figure of bench.json's summary."""
    low, _, high = result("bench.json")["default_summary"]["min_median_max"][name]
    return low, high

# -- the claim sweep on the low-rate command path, on the fixed code (claims-tail-v3) --------------------------------
TAIL_V3 = "claims_tail_v3.json"   # the judged runs (pooled series, the tail carried past a late touch)
TAIL = "claims_tail_v3_statistics.json"   # their statistics per cell, law and hand


def planned_claim_runs() -> int:
    """The runs the claim sweep plans (every cell, law, hand and seed; fic_teleop_experiments.claims)."""
    from fic_teleop_experiments.claims import claim_runs

    return len(claim_runs())


def stable_runs(summary: str) -> int:
    """The runs of a judged sweep (claims_sweep --judge) whose verdict is stable."""
    return sum(bool((row.get("verdict") or {}).get("stable")) for row in result(summary)["runs"])


def claim_cells(delay: float) -> list[dict]:
    """The cells at ``delay`` with force feedback (every rate and hand; the open-loop controls left out)."""
    return [c for c in result(TAIL)["cells"] if c["delay"] == delay and "feedback_off" not in c["cell"]]


def tail_stable(delay: float, laws: tuple[str, ...] = ("fic", *BASELINES)) -> tuple[int, int]:
    """(stable, judged) over the claim cells at ``delay`` and ``laws``."""
    shares = [c["laws"][law]["stable"] for c in claim_cells(delay) for law in laws if law in c["laws"]]
    return sum(s["k"] for s in shares), sum(s["n"] for s in shares)


def control_stable() -> tuple[int, int]:
    """(stable, judged) over the open-loop control cells (the force feedback off), every law."""
    shares = [law["stable"] for c in result(TAIL)["cells"] if "feedback_off" in c["cell"] for law in c["laws"].values()]
    return sum(s["k"] for s in shares), sum(s["n"] for s in shares)


def tail_error_range(laws: tuple[str, ...]) -> str:
    """The range of the median RMS tracking error [mm] of the claim cells at 1 s or less over ``laws``, as RESULTS.md
    writes it."""
    values = [c["laws"][law]["error_rms_median"] * 1e3 for delay in sorted({c["delay"] for c in result(TAIL)["cells"]})
              if delay <= 1.0 for c in claim_cells(delay) for law in laws]
    return f"{min(values):.1f}-{max(values):.1f}"


def tail_start_stable(where: str, law: str, delay: float = 1.0, sweep: str = "claims_tail_v3") -> str:
    """"k of n" stable at ``delay`` for ``law`` over the claim runs whose quiet tail begins ``where`` ("off" or "on" the
    fixed obstacle; results/<sweep>_<where>_obstacle_statistics.json, fic_teleop_experiments.tail_start)."""
    shares = [c["laws"][law]["stable"] for c in result(f"{sweep}_{where}_obstacle_statistics.json")["cells"]
              if c["delay"] == delay and law in c["laws"] and "feedback_off" not in c["cell"]]   # no control
    return f"{sum(s['k'] for s in shares)} of {sum(s['n'] for s in shares)}"


def link_hold_gains(design: str, rate_hz: float = 10.0) -> str:
    """The range of the FIC's peak gain over the runs of one hold design at one link rate
    (results/link_hold_designs.json)."""
    gains = [r["peak_gain"] for r in result("link_hold_designs.json")["runs"]
             if r["design"] == design and r["rate_hz"] == rate_hz]
    return f"{min(gains):.2f}-{max(gains):.2f}"


FIGURES = [
    # -- README's table -------------------------------------------------------------------------------------------
    Figure("README: the main job's error, latency and limits", "README",
           r"free-motion error max (?P<max_low>[\d.]+)-(?P<max_high>[\d.]+) mm \(x_b 50 mm\), RMS "
           r"(?P<rms_low>[\d.]+)-(?P<rms_high>[\d.]+) mm \(target 10\); latency p99 (?P<p99_low>[\d.]+)-"
           r"(?P<p99_high>[\d.]+) ms; (?P<violations>\d+) limit violations",
           lambda: dict(max_low=f"{bench_range('free_motion_error_max_mm')[0]:.1f}",
                        max_high=f"{bench_range('free_motion_error_max_mm')[1]:.1f}",
                        rms_low=f"{bench_range('free_motion_error_rms_mm')[0]:.1f}",
                        rms_high=f"{bench_range('free_motion_error_rms_mm')[1]:.1f}",
                        p99_low=f"{bench_range('pipeline_latency_p99_ms')[0]:.1f}",
                        p99_high=f"{bench_range('pipeline_latency_p99_ms')[1]:.1f}",
                        violations=str(max(run["metrics"]["limit_violations"]
                                               for run in result("bench.json")["default_runs"])))),
    Figure("README: E1 lockstep", "README",
           r"E1 superimposition, lockstep \| free-motion error max (?P<max>[\d.]+) mm, RMS (?P<rms>[\d.]+) mm; "
           r"(?P<violations>\d+) limit violations",
           lambda: dict(max=mm(result("e1.json")["metrics"]["free_motion_error_max_m"]),
                        rms=mm(result("e1.json")["metrics"]["free_motion_error_rms_m"]),
                        violations=str(result("e1.json")["limits"]["violation_ticks"]))),
    Figure("README: E2 on the graph and in process", "README",
           r"graph: the FIC completes (?P<complete>\d+) of (?P<trials>\d+) trials \(the paper: 4 of 4\); in process: "
           r"(?P<in_process>\d+ of \d+)",
           lambda: dict(complete=graph_trials("e2_graph_fic.jsonl", r"the FIC completes \d+ of (?P<trials>\d+) graph "
                                                                    r"trials")["complete"],
                        trials=str(len(jsonl("e2_graph_fic.jsonl"))),
                        in_process=e2_sweep_at_200ms().get("fic", "none"))),
    Figure("README: E3", "README",
           r"energy peak (?P<before>[\d.]+) J before, (?P<after>[\d.]+) J after; (?P<violations>\d+) limit violations",
           lambda: dict(before=f"{result('e3.json')['blackout']['energy_max_before_j']:.3f}",
                        after=f"{result('e3.json')['blackout']['energy_max_after_j']:.3f}",
                        violations=str(result("e3.json")["blackout"]["violation_ticks_after"]))),
    Figure("README: the FIC's gain at 10 Hz with the interpolating hold", "README",
           r"the FIC's peak gain from the received offset to the arm (?P<gains>[\d.]+-[\d.]+) \|",
           lambda: dict(gains=link_hold_gains("interpolate"))),
    # -- RESULTS.md: the main job and E1-E4 ------------------------------------------------------------------------
    Figure("bench: free-motion error of the ten default runs", "RESULTS",
           r"max (?P<max_low>[\d.]+)-(?P<max_high>[\d.]+) mm, RMS (?P<rms_low>[\d.]+)-(?P<rms_high>[\d.]+) mm: both "
           r"targets in (?P<met>\d+) of (?P<runs>\d+)",
           lambda: dict(max_low=f"{bench_range('free_motion_error_max_mm')[0]:.1f}",
                        max_high=f"{bench_range('free_motion_error_max_mm')[1]:.1f}",
                        rms_low=f"{bench_range('free_motion_error_rms_mm')[0]:.1f}",
                        rms_high=f"{bench_range('free_motion_error_rms_mm')[1]:.1f}",
                        met=str(min(result("bench.json")["default_summary"]["met"][target] for target in (
                            "free-motion error max < 50 mm", "free-motion error RMS < 10 mm"))),
                        runs=str(result("bench.json")["default_summary"]["runs"]))),
    Figure("bench: latency and loop rates of the ten default runs", "RESULTS",
           r"p99 (?P<p99_low>[\d.]+)-(?P<p99_high>[\d.]+) ms \(under 5 ms in (?P<under>\d+) of (?P<runs>\d+)\); "
           r"median (?P<p50_low>[\d.]+)-(?P<p50_high>[\d.]+) ms .{0,60}?every loop at (?P<loop>[\d.]+) % of its rate",
           lambda: dict(p99_low=f"{bench_range('pipeline_latency_p99_ms')[0]:.1f}",
                        p99_high=f"{bench_range('pipeline_latency_p99_ms')[1]:.1f}",
                        under=str(result("bench.json")["default_summary"]["met"]["latency p99 < 5 ms"]),
                        runs=str(result("bench.json")["default_summary"]["runs"]),
                        p50_low=f"{min(bench_runs('pipeline_latency_p50_ms')):.1f}",
                        p50_high=f"{max(bench_runs('pipeline_latency_p50_ms')):.1f}",
                        loop=f"{100 * bench_range('slowest_loop_fraction')[0]:.1f}")),
    Figure("E1 lockstep: errors, force and limits", "RESULTS",
           r"free-motion error max (?P<max>[\d.]+) mm, RMS (?P<rms>[\d.]+) mm; contact error max (?P<contact>[\d.]+) "
           r"mm; peak force (?P<force>[\d.]+) N; (?P<violations>\d+) limit violations",
           lambda: dict(max=mm(result("e1.json")["metrics"]["free_motion_error_max_m"]),
                        rms=mm(result("e1.json")["metrics"]["free_motion_error_rms_m"]),
                        contact=mm(result("e1.json")["metrics"]["contact_error_max_m"]),
                        force=f"{result('e1.json')['metrics']['peak_interaction_force_n']:.1f}",
                        violations=str(result("e1.json")["limits"]["violation_ticks"]))),
    Figure("E3: energy, limits, force and error after the loss", "RESULTS",
           r"energy max (?P<before>[\d.]+) J before / (?P<after>[\d.]+) J after the loss; after it (?P<violations>\d+) "
           r"violation ticks, peak force (?P<force>[\d.]+) N, error at most (?P<error>[\d.]+) mm",
           lambda: dict(before=f"{result('e3.json')['blackout']['energy_max_before_j']:.3f}",
                        after=f"{result('e3.json')['blackout']['energy_max_after_j']:.3f}",
                        violations=str(result("e3.json")["blackout"]["violation_ticks_after"]),
                        force=f"{result('e3.json')['blackout']['peak_force_after_n']:.1f}",
                        error=mm(result("e3.json")["blackout"]["error_max_after_m"]))),
    # -- RESULTS.md: the low-rate command path and the claim sweep on it -----------------------------------------
    Figure("the FIC's gain at 10 Hz, both hold designs", "RESULTS",
           r"interpolating hold (?P<interpolate>[\d.]+-[\d.]+), extrapolating hold (?P<extrapolate>[\d.]+-[\d.]+) "
           r"\(the hold before: [\d.]+\); (?P<stable>\d+) of (?P<runs>\d+) runs stable",
           lambda: dict(interpolate=link_hold_gains("interpolate"), extrapolate=link_hold_gains("extrapolate"),
                        stable=str(sum(bool(r["stable"]) for r in result("link_hold_designs.json")["runs"])),
                        runs=str(len(result("link_hold_designs.json")["runs"])))),
    Figure("claims on the fixed code: runs judged", "RESULTS",
           r"judged by the free response \| (?P<judged>[\d,]+) of (?P<planned>[\d,]+);",
           lambda: dict(judged=f"{result(TAIL)['runs_judged']:,}",
                        planned=f"{planned_claim_runs():,}")),
    Figure("README: the claim sweep on the fixed code", "README",
           r"on the fixed code \(claims-tail-v3, complete\): (?P<judged>[\d,]+) of (?P<planned>[\d,]+) runs judged, "
           r"(?P<stable>[\d,]+) stable",
           lambda: dict(judged=f"{result(TAIL_V3)['runs_judged']:,}", planned=f"{planned_claim_runs():,}",
                        stable=f"{stable_runs(TAIL_V3):,}")),
    Figure("claims on the fixed code: the false-alarm floor", "RESULTS",
           r"false-alarm floor at zero delay (?P<zero>\d+ of \d+) stable, every law",
           lambda: dict(zero="{} of {}".format(*tail_stable(0.0)))),
    Figure("claims on the fixed code: 0.2 s", "RESULTS",
           r"every law; at 0\.2 s (?P<stable>\d+ of \d+) stable",
           lambda: dict(stable="{} of {}".format(*tail_stable(0.2)))),
    Figure("claims on the fixed code: 1 s, by law", "RESULTS",
           r"the FIC (?P<fic>\d+) of (?P<n>\d+), linear (?P<linear>\d+), linear_bounded (?P<linear_bounded>\d+), "
           r"linear_tdpa (?P<linear_tdpa>\d+), fic_paper_law (?P<fic_paper_law>\d+)",
           lambda: dict(n=str(tail_stable(1.0, ("fic",))[1]),
                        **{law: str(tail_stable(1.0, (law,))[0]) for law in ("fic", *BASELINES)})),
    *(Figure(f"claims: 1 s, the tail begun {where} the obstacle", "RESULTS",
             rf"\| {where} the obstacle \| (?P<fic>\d+ of \d+) "
             rf"\| (?P<fic_paper_law>\d+ of \d+) "
             rf"\| (?P<linear>\d+ of \d+) \| (?P<linear_bounded>\d+ of \d+) \| (?P<linear_tdpa>\d+ of \d+) \|",
             lambda where=where: {law: tail_start_stable(where, law) for law in ("fic", *BASELINES)})
      for where in ("off", "on")),
    Figure("claims on the fixed code: tracking error", "RESULTS",
           r"the FIC (?P<fic>[\d.]+-[\d.]+) mm, linear and linear_bounded (?P<linear>[\d.]+-[\d.]+) mm, linear_tdpa "
           r"(?P<tdpa>[\d.]+-[\d.]+) mm",
           lambda: dict(fic=tail_error_range(("fic",)), linear=tail_error_range(("linear", "linear_bounded")),
                        tdpa=tail_error_range(("linear_tdpa",)))),
    Figure("claims: the open-loop controls", "RESULTS",
           r"The open-loop controls \(K_H = 0,\s+1 s and 0\.2 s at 10 Hz, reactive hand\) settle in "
           r"(?P<share>\d+ of \d+) runs, every law",
           lambda: dict(share="{} of {}".format(*control_stable()))),
    Figure("README: the open-loop controls", "README",
           r"with the force feedback off every law settles, (?P<share>\d+ of \d+)",
           lambda: dict(share="{} of {}".format(*control_stable()))),
    Figure("claims beyond the claim cells: 2 s, 0.5 and 1.5 s", "RESULTS",
           r"at 2 s the FIC (?P<fic>\d+) of (?P<n>\d+)\s+\(fic_paper_law (?P<fic_paper_law>\d+), linear_tdpa "
           r"(?P<linear_tdpa>\d+), linear (?P<linear>\d+), linear_bounded (?P<linear_bounded>\d+)\); at 0\.5 and "
           r"1\.5 s \(full rate\) the FIC (?P<half>\d+ of \d+) and\s+(?P<one_half>\d+ of \d+)",
           lambda: dict(n=str(tail_stable(2.0, ("fic",))[1]), **{law: str(tail_stable(2.0, (law,))[0])
                                                                  for law in ("fic", *BASELINES)},
                        half="{} of {}".format(*tail_stable(0.5, ("fic",))),
                        one_half="{} of {}".format(*tail_stable(1.5, ("fic",))))),
    Figure("the run verdict on its labelled cases", "RESULTS",
           r"(?P<right>\d+) of (?P<cases>\d+) right; held-out seeds: (?P<false>\d+) of (?P<stable>\d+) false alarms, "
           r"(?P<missed>\d+) of (?P<cycles>\d+) limit cycles missed",
           lambda: dict(right=str(result("verdict_validation.json")["right"]),
                        cases=str(result("verdict_validation.json")["cases"]),
                        false=str(len(result("verdict_validation.json")["held_out"]["false_alarms"])),
                        stable=str(result("verdict_validation.json")["held_out"]["stable_runs"]),
                        missed=str(len(result("verdict_validation.json")["held_out"]["missed"])),
                        cycles=str(result("verdict_validation.json")["held_out"]["limit_cycle_runs"]))),
    # -- RESULTS.md: shape sorting -----------------------------------------------------------------------------------
    Figure("E2 graph, the replica's default law at 200 ms: trials complete and their interval", "RESULTS",
           r"the FIC completes (?P<complete>\d+) of (?P<trials>\d+) graph trials "
           r"\(Wilson (?P<low>[\d.]+)-(?P<high>[\d.]+)\)",
           lambda: graph_trials("e2_graph_fic.jsonl", r"the FIC completes \d+ of (?P<trials>\d+) graph trials")),
    Figure("E2 graph, the replica's default law: pieces, their interval, peak forces", "RESULTS",
           r"default law (?P<inside>\d+) of (?P<pieces>\d+) pieces \((?P<low>[\d.]+)-(?P<high>[\d.]+)\), "
           r".{0,30}?, peak (?P<peak_low>[\d.]+)-(?P<peak_high>[\d.]+) N",
           lambda: dict(inside=str(sum(len(t["pieces_inside"]) for t in jsonl("e2_graph_fic.jsonl"))),
                        pieces=str(3 * len(jsonl("e2_graph_fic.jsonl"))),
                        **interval(sum(len(t["pieces_inside"]) for t in jsonl("e2_graph_fic.jsonl")),
                                   3 * len(jsonl("e2_graph_fic.jsonl"))),
                        peak_low=f"{min(t['peak_force_n'] for t in jsonl('e2_graph_fic.jsonl')):.1f}",
                        peak_high=f"{max(t['peak_force_n'] for t in jsonl('e2_graph_fic.jsonl')):.1f}")),
    Figure("E2 graph, Eq. 7 as written at 200 ms: trials complete and their interval", "RESULTS",
           r"Eq\. 7 as written (?P<complete>\d+) of (?P<trials>\d+) graph trials \((?P<low>[\d.]+)-(?P<high>[\d.]+)\)",
           lambda: graph_trials("e2_graph_stamped.jsonl", r"Eq\. 7 as written \d+ of (?P<trials>\d+) graph trials")),
    Figure("E2 graph, the unbounded linear law at 200 ms: trials complete and their interval", "RESULTS",
           r"linear (?P<complete>\d+) of (?P<trials>\d+) graph trials \((?P<low>[\d.]+)-(?P<high>[\d.]+)\)",
           lambda: graph_trials("e2_graph_linear.jsonl", r"linear \d+ of (?P<trials>\d+) graph trials")),
    Figure("E2 in process at 200 ms, every law (checked on the seeds RESULTS.md counts)", "RESULTS",
           r"at 200 ms: the default FIC (?P<fic>\d+ of \d+) \((?P<low>[\d.]+)-(?P<high>[\d.]+)\), as written "
           r"(?P<fic_paper_law>\d+ of \d+) \([\d.]+-[\d.]+\), linear (?P<linear>\d+ of \d+), linear_bounded "
           r"(?P<linear_bounded>\d+ of \d+), linear_tdpa (?P<linear_tdpa>\d+ of \d+)",
           lambda: e2_sweep_at_200ms()),
    Figure("E2 in process at 0, 0.5 and 1 s, every law, 10 seeds each", "RESULTS",
           r"At 0, 0\.5 and 1 s \(10 seeds each\): the default FIC (?P<fic>\d+, \d+ and \d+) of 10, as written "
           r"(?P<fic_paper_law>\d+, \d+ and \d+), linear (?P<linear>\d+, \d+ and \d+), linear_bounded "
           r"(?P<linear_bounded>\d+, \d+ and \d+), linear_tdpa (?P<linear_tdpa>\d+, \d+ and \d+)",
           lambda: e2_sweep_other_delays()),
    Figure("E2 on the new command path in process, every law, 10 seeds", "RESULTS",
           r"in process, 10 seeds a law, trials complete: the FIC (?P<fic>\d+ of \d+), as written "
           r"(?P<fic_paper_law>\d+ of \d+), linear (?P<linear>\d+ of \d+), "
           r"linear_bounded (?P<linear_bounded>\d+ of \d+), linear_tdpa (?P<linear_tdpa>\d+ of \d+)",
           lambda: {law: "{} of {}".format(*complete_of(jsonl("e2_sweep_link_hold.jsonl"), law, 0.2, 10))
                    for law in ("fic", "fic_paper_law", "linear", "linear_bounded", "linear_tdpa")}),
    Figure("E2 on the new command path: the FIC's graph trials", "RESULTS",
           r"graph, seeds 1-4: the FIC completes (?P<complete>\d+) of (?P<trials>\d+) trials",
           lambda: {key: value for key, value in graph_trials(
               "e2_graph_fic_link_hold.jsonl", r"graph, seeds 1-4: the FIC completes \d+ of (?P<trials>\d+) trials"
           ).items() if key in ("complete", "trials")}),
]


def found_in(figure: Figure, text: str | None = None) -> list[re.Match]:
    return list(re.finditer(figure.pattern, DOCUMENTS[figure.where]() if text is None else text))


@pytest.mark.parametrize("figure", FIGURES, ids=[figure.name for figure in FIGURES])
def test_documented_figure_matches_its_results_file(figure: Figure):
    found = found_in(figure)
    assert len(found) == 1, f"{figure.where} should say this once: {figure.pattern}"
    assert found[0].groupdict() == figure.expected()


def test_the_checks_fail_on_a_wrong_figure():
    """The machinery itself: a figure one digit off in either document no longer matches its results file."""
    for name, group in (("E1 lockstep: errors, force and limits", "max"), ("README: E1 lockstep", "rms")):
        figure = next(f for f in FIGURES if f.name == name)
        match = found_in(figure)[0]
        written = match.group(group)
        wrong_text = (match.string[:match.start(group)] + f"{float(written) + 0.1:.1f}"
                      + match.string[match.end(group):])
        wrong = found_in(figure, wrong_text)
        assert len(wrong) == 1 and wrong[0].groupdict() != figure.expected(), name


def test_the_readme_table_gives_a_date_and_a_results_section_a_row():
    """README's results are a short table: a handful of rows, each dated and pointing at a section of RESULTS.md."""
    text = (REPO / "README.md").read_text()
    section = text[text.index("## Results"):]
    rows = [line for line in section[:section.index("\n## ", 1)].splitlines()
            if line.startswith("| ") and not line.startswith("| what ")]
    headings = set(re.findall(r"^#+ (.+)$", (REPO / "docs" / "RESULTS.md").read_text(), re.MULTILINE))
    assert 3 <= len(rows) <= 8, rows
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert re.fullmatch(r"\d{4}-\d{2}-\d{2}", cells[-2]), row
        assert any(cells[-1].strip('"') == h or h.startswith(cells[-1].strip('"')) for h in headings), row


# -- the claim sweep: RESULTS.md's generated block and the statistics behind it -----------------------------------
def test_claims_block_is_generated_from_the_statistics():
    """docs/RESULTS.md's block on the FIC papers' claims is claims_report's from the sweep on the fixed code
    (results/claims_tail_v3_statistics.json), to the character (a figure changed by hand, or statistics regenerated
    without the page, fails here)."""
    from fic_teleop_experiments.tables import claims_block

    text = (REPO / "docs" / "RESULTS.md").read_text()
    assert text.count(CLAIMS_BEGIN) == 1 and text.count(CLAIMS_END) == 1, "RESULTS.md holds one claims block"
    start = text.index("\n", text.index(CLAIMS_BEGIN)) + 1
    assert text[start:text.index(CLAIMS_END, start)] == claims_block(result("claims_tail_v3_statistics.json")), (
        "regenerate: python -m fic_teleop_experiments.claims_report results/claims_tail_v3.json --update-results "
        "docs/RESULTS.md")
    assert CLAIMS_BEGIN not in (REPO / "README.md").read_text(), "the claims block lives in docs/RESULTS.md"


@pytest.mark.parametrize("statistics, summary", [("claims_tail_v3_statistics.json", "claims_tail_v3.json")])
def test_claims_statistics_are_those_of_the_judged_sweep(statistics: str, summary: str):
    """The sweep's statistics recomputed from its judged runs (every run with both verdicts), written again with
    each judge pass."""
    from fic_teleop_experiments.claims_report import claims_statistics, read_runs

    written = result(statistics)
    again = json.loads(json.dumps(claims_statistics(read_runs(REPO / "results" / summary),
                                                    written["seeds_planned"])))
    for field in ("runs_total", "runs_judged", "runs_judged_stable", "cells"):
        assert written[field] == again[field], field
    assert len(written["comparisons"]) == len(again["comparisons"])
    for ours, theirs in zip(written["comparisons"], again["comparisons"]):
        for verdict in ("stable", "safe"):
            for key in ("reference_k_n", "baseline_k_n"):
                assert ours[verdict][key] == theirs[verdict][key], (ours["cell"], verdict, key)
            for key in ("difference", "boschloo_p", "fisher_p"):
                expected = theirs[verdict][key]
                assert ours[verdict][key] == (None if expected is None else pytest.approx(expected, abs=1e-6)), \
                    (ours["cell"], key)
