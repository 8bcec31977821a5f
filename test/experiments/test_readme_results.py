"""README's "Results" figures against the results/*.json they come from: a table of checks, one row a figure (or a
group of figures in one sentence). Each row finds its sentence in README (whitespace-normalised, exactly once) and
compares every captured figure with the JSON, formatted as README writes it. A new result in README gets a row here."""
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
    """An E2 trial is complete when every piece ended inside the box (as e2_sweep's summary counts it)."""
    return len(trial["pieces_inside"]) == len(PIECE_NAMES)


def interval(k: int, n: int) -> dict:
    low, high = wilson_interval(k, n)
    return dict(low=f"{low:.2f}", high=f"{high:.2f}")


def complete_of(trials: list[dict], law: str, delay: float, seeds: int) -> tuple[int, int]:
    """(trials complete, trials) of one sweep cell over its seeds 1..``seeds`` (a seed counted once)."""
    kept = {t["seed"]: t for t in trials if t["law"] == law and t["delay_s"] == delay and t["seed"] <= seeds}
    return sum(complete(t) for t in kept.values()), len(kept)


def e2_sweep_at_200ms() -> dict:
    """The in-process sweep keeps running and appending trials (seed-major), so the README states k of n for its
    first n seeds a law: each k is recomputed from results/e2_sweep.jsonl's trials of seeds 1..n, and the FIC's
    interval from them."""
    said = re.search(r"at 200 ms: the default FIC \d+ of (?P<fic>\d+) .*?as written \d+ of (?P<fic_paper_law>\d+) .*?"
                     r"linear \d+ of (?P<linear>\d+), linear_bounded \d+ of (?P<linear_bounded>\d+), linear_tdpa \d+ "
                     r"of "
                     r"(?P<linear_tdpa>\d+)", readme_results())
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
    """README's trials complete at 0, 0.5 and 1 s for every law, from results/e2_sweep.jsonl's seeds 1..10."""
    trials = jsonl("e2_sweep.jsonl")
    expected = {}
    for law in ("fic", "fic_paper_law", "linear", "linear_bounded", "linear_tdpa"):
        counts = [complete_of(trials, law, delay, 10)[0] for delay in (0.0, 0.5, 1.0)]
        expected[law] = f"{counts[0]}, {counts[1]} and {counts[2]}"
    return expected


def graph_trials(file: str, said: str) -> dict:
    """README's k of n for a law on the graph: its first n trials in the jsonl (n as README says it), so that a trial
    still running when README was written, appended later, does not change the figure; with its Wilson interval."""
    found = re.search(said, readme_results())
    trials = jsonl(file)[:int(found.group("trials"))] if found else []
    k = sum(complete(t) for t in trials)
    return dict(complete=str(k), trials=str(len(trials)), **(interval(k, len(trials)) if trials else {}))


@cache
def readme_results() -> str:
    text = (REPO / "README.md").read_text()
    section = text[text.index("## Results"):]
    section = section[:section.index("\n## ", 1)]
    return " ".join(section.split())


def cell(file: str, cell_id: str, controller: str) -> dict:
    return next(c["statistics"] for c in result(file)["cells"]
                if c["cell"] == cell_id and c["controller"] == controller)


def stable_count(file: str, cell_id: str, controller: str) -> str:
    return str(cell(file, cell_id, controller)["stable"])


def one_count_of(values) -> str:
    """README gives one figure for several laws, cells or baselines: it must be the same for all of them."""
    found = set(values)
    return found.pop() if len(found) == 1 else f"differs: {sorted(found)}"


def one_count(file: str, cell_id: str, controllers: tuple[str, ...], *more_cells: str) -> str:
    """The stable count README gives for several laws (or cells) at once: it must be the same for all of them."""
    return one_count_of(str(cell(file, c_id, c)["stable"]) for c_id in (cell_id, *more_cells) for c in controllers)


def mm(metres: float) -> str:
    return f"{metres * 1e3:.1f}"


@dataclass(frozen=True)
class Figure:
    name: str
    pattern: str                                  # regex on README's Results section, named groups = figures
    expected: Callable[[], dict[str, str]]        # the same names, from results/*.json, as README writes them


BOUNDED = ("fic", "fic_paper_law", "linear_bounded", "linear_tdpa")
BASELINES = ("fic_paper_law", "linear", "linear_bounded", "linear_tdpa")
CLOSED_LOOP = "evidence_closed_loop_5seeds.json"


def bench_runs(name: str) -> list[float]:
    return [run[name] for run in result("bench.json")["default_runs"]]


def bench_range(name: str) -> tuple[float, float]:
    """(min, max) over the ten default runs of a figure of bench.json's summary."""
    low, _, high = result("bench.json")["default_summary"]["min_median_max"][name]
    return low, high

def claim_share(cell_id: str, hand: str, law: str = "fic", verdict: str = "stable") -> dict:
    """A law's stable (or safe) share {k, n, interval_95} on a claim cell (results/claims_statistics.json)."""
    return next(c for c in result("claims_statistics.json")["cells"]
                if c["cell"] == cell_id and c.get("hand") == hand)["laws"][law][verdict]


def k_n(share: dict) -> str:
    return f"{share['k']}/{share['n']}"


def peak_gain(law: str) -> dict:
    """A law's response on the 1 s + 10 Hz open-loop control (results/replica_response.json)."""
    return next(r for r in result("replica_response.json")["responses"]
                if r["cell"] == "delay_1__rate_10__feedback_off" and r["law"] == law)


def quartiles_at_peak(law: str) -> tuple[float, float]:
    response = peak_gain(law)
    index = response["gain_median"].index(max(response["gain_median"]))
    return response["gain_q25"][index], response["gain_q75"][index]


LINEAR_LAWS = ("linear", "linear_bounded", "linear_tdpa")


def refit(cell_id: str) -> dict:
    """The FIC's reactive-hand runs of a cell judged with and without the forced-answer fit
    (results/verdict_forced_answer_claims.json, fic_teleop_experiments.verdict_cases --claims-cells)."""
    return result("verdict_forced_answer_claims.json")["by_cell_and_law"][f"{cell_id} fic"]


def refit_k_n(cell_id: str, field: str = "stable") -> str:
    return f"{refit(cell_id)[field]}/{refit(cell_id)['runs']}"


def comparison(cell_id: str, hand: str, baseline: str) -> dict:
    """FIC against one baseline on a claim cell and hand: stable-share difference, interval, Boschloo p."""
    return next(c for c in result("claims_statistics.json")["comparisons"]
                if c["cell"] == cell_id and c.get("hand") == hand and c["baseline"] == baseline)["stable"]


def p_text(p: float) -> str:
    return f"{p:.3f}"


SWEEP_DELAYS = ("0", "0.2", "0.5", "1", "1.5", "2")


def against_each(cell_id: str, figure: str, hand: str = "reactive") -> list[float]:
    """A figure of the FIC's comparison with each baseline on a claim cell (difference, boschloo_p, ...)."""
    return [comparison(cell_id, hand, baseline)[figure] for baseline in BASELINES]


def safe_range(laws: tuple[str, ...]) -> tuple[int, int]:
    """(least, most) SAFE runs of ``laws`` at 1.5 and 2 s, full rate, either hand."""
    counts = [claim_share(f"delay_{d}__rate_full", hand, law, "safe")["k"] for d in ("1.5", "2")
              for hand in ("passive", "reactive") for law in laws]
    return min(counts), max(counts)


def delay_sweep(hand: str) -> str:
    return ", ".join(str(claim_share(f"delay_{d}__rate_full", hand)["k"]) for d in SWEEP_DELAYS[:-1]) + \
        f" and {claim_share('delay_2__rate_full', hand)['k']}"


def above_paper_law() -> dict:
    """Where the FIC is above the paper's own law in the full-rate delay sweep (Boschloo p < 0.05, either hand)."""
    found = [(cell["cell"], comparison(cell["cell"], cell["hand"], "fic_paper_law"))
             for cell in result("claims_statistics.json")["cells"] if cell["cell"].endswith("__rate_full")]
    found = [(c, s) for c, s in found if s["difference"] > 0 and s["boschloo_p"] < 0.05]
    delays = sorted({float(c.split("__")[0][len("delay_"):]) for c, _ in found})
    names = [f"{d:g}" for d in delays]
    return dict(delays=", ".join(names[:-1]) + f" and {names[-1]}",
                low=f"{min(s['difference'] for _, s in found):.2f}",
                high=f"{max(s['difference'] for _, s in found):.2f}",
                p_high=p_text(max(s["boschloo_p"] for _, s in found)),
                p_low="below 0.001" if min(s["boschloo_p"] for _, s in found) < 0.001
                else p_text(min(s["boschloo_p"] for _, s in found)))


FIGURES = [
    Figure("claims: the passive hand's reproduced rows",
           r"The whole sweep \(2026-12-05, (?P<runs>[\d,]+) runs\): at 1 s with the link at full rate, and at the "
           r"paper's 0\.2 s "
           r"with the link at 10 Hz, the FIC is stable in (?P<full>\d+/\d+) and (?P<ten>\d+/\d+) runs with the passive",
           lambda: dict(runs=f"{result('claims_statistics.json')['runs_judged']:,}",
                        full=k_n(claim_share("delay_1__rate_full", "passive")),
                        ten=k_n(claim_share("delay_0.2__rate_10", "passive")))),
    Figure("claims: the reactive hand at 1 s, full rate",
           r"with the force-reactive hand (?P<fic>\d+/\d+) at 1 s full rate",
           lambda: dict(fic=k_n(claim_share("delay_1__rate_full", "reactive")))),
    Figure("claims: 0.2 s + 10 Hz with the reactive hand, against every baseline",
           r"at the paper's 0\.2 s \((?P<fic>\d+/\d+) against (?P<low>\d+)-(?P<high>\d+)/20; FIC minus each baseline "
           r"(?P<d_least>-[\d.]+) to (?P<d_most>-[\d.]+), Boschloo p (?P<p_low>[\d.]+)-(?P<p_high>[\d.]+)\)",
           lambda: dict(fic=k_n(claim_share("delay_0.2__rate_10", "reactive")),
                        low=str(min(claim_share("delay_0.2__rate_10", "reactive", b)["k"] for b in BASELINES)),
                        high=str(max(claim_share("delay_0.2__rate_10", "reactive", b)["k"] for b in BASELINES)),
                        d_most=f"{min(against_each('delay_0.2__rate_10', 'difference')):.2f}",
                        d_least=f"{max(against_each('delay_0.2__rate_10', 'difference')):.2f}",
                        p_low=p_text(min(against_each("delay_0.2__rate_10", "boschloo_p"))),
                        p_high=p_text(max(against_each("delay_0.2__rate_10", "boschloo_p"))))),
    Figure("claims: 1 s + 10 Hz with the passive hand",
           r"at 1 s with both 10 Hz and the passive hand, (?P<fic>\d+/\d+) \(undecided\)",
           lambda: dict(fic=k_n(claim_share("delay_1__rate_10", "passive")))),
    Figure("claims: the delay sweep at full rate, both hands",
           r"the FIC is stable in (?P<passive>[\d, ]+ and \d+) of 20 with the passive hand at 0, 0\.2, 0\.5, 1, 1\.5 "
           r"and 2 s, "
           r"and (?P<reactive>[\d, ]+ and \d+) with the reactive one",
           lambda: dict(passive=delay_sweep("passive"), reactive=delay_sweep("reactive"))),
    Figure("claims: the delay sweep against the paper's own law",
           r"above the paper's own law at (?P<delays>[\d., ]+ and [\d.]+) s \(with one hand or both, by "
           r"(?P<low>[\d.]+)-(?P<high>[\d.]+), Boschloo p (?P<p_low>below 0\.001|[\d.]+) to (?P<p_high>[\d.]+)\)",
           above_paper_law),
    Figure("claims: 1.5 s with the passive hand",
           r"1\.5 s with the passive hand \((?P<fic>\d+/\d+) against `linear_bounded`'s and `linear_tdpa`'s "
           r"(?P<base>\d+/\d+), (?P<d>-[\d.]+), p (?P<p>[\d.]+)\)",
           lambda: dict(fic=k_n(claim_share("delay_1.5__rate_full", "passive")),
                        base=one_count_of(k_n(claim_share("delay_1.5__rate_full", "passive", b))
                                          for b in ("linear_bounded", "linear_tdpa")),
                        d=one_count_of(f"{comparison('delay_1.5__rate_full', 'passive', b)['difference']:.2f}"
                                       for b in ("linear_bounded", "linear_tdpa")),
                        p=one_count_of(p_text(comparison("delay_1.5__rate_full", "passive", b)["boschloo_p"])
                                       for b in ("linear_bounded", "linear_tdpa")))),
    Figure("claims: 2 s at 10 and 5 Hz, reactive hand, against linear_bounded",
           r"\((?P<fic10>\d+/\d+) against (?P<lb10>\d+/\d+) at 10 Hz, (?P<fic5>\d+/\d+) against (?P<lb5>\d+/\d+) at 5 "
           r"Hz, "
           r"p (?P<p10>[\d.]+) and (?P<p5>[\d.]+)\)",
           lambda: dict(fic10=k_n(claim_share("delay_2__rate_10", "reactive")),
                        lb10=k_n(claim_share("delay_2__rate_10", "reactive", "linear_bounded")),
                        fic5=k_n(claim_share("delay_2__rate_5", "reactive")),
                        lb5=k_n(claim_share("delay_2__rate_5", "reactive", "linear_bounded")),
                        p10=p_text(comparison("delay_2__rate_10", "reactive", "linear_bounded")["boschloo_p"]),
                        p5=p_text(comparison("delay_2__rate_5", "reactive", "linear_bounded")["boschloo_p"]))),
    Figure("claims: SAFE beyond 1 s at full rate",
           r"the FIC (?P<fic_low>\d+)-(?P<fic_high>\d+) of 20 at 1\.5-2 s full rate, the baselines "
           r"(?P<base_low>\d+)-(?P<base_high>\d+)\)",
           lambda: dict(zip(("fic_low", "fic_high"), map(str, safe_range(("fic",)))),
                        **dict(zip(("base_low", "base_high"), map(str, safe_range(BASELINES)))))),
    Figure("claims: 1 s + 10 Hz with the reactive hand, against linear_tdpa",
           r"\((?P<fic>\d+/\d+) at 1 s, below `linear_tdpa`'s (?P<tdpa>\d+/\d+), Boschloo p (?P<p>[\d.]+)\)",
           lambda: dict(fic=k_n(claim_share("delay_1__rate_10", "reactive")),
                        tdpa=k_n(claim_share("delay_1__rate_10", "reactive", "linear_tdpa")),
                        p=p_text(comparison("delay_1__rate_10", "reactive", "linear_tdpa")["boschloo_p"]))),
    Figure("claims: the open-loop control at 1 s + 10 Hz",
           r"the FIC is as often unstable, (?P<control>\d+/\d+) stable at 1 s and (?P<control_02>\d+/\d+) at 0\.2 s "
           r"\((?P<closed_02>\d+/\d+) with the loop\)\.",
           lambda: dict(control=k_n(claim_share("delay_1__rate_10__feedback_off", "reactive")),
                        control_02=k_n(claim_share("delay_0.2__rate_10__feedback_off", "reactive")),
                        closed_02=k_n(claim_share("delay_0.2__rate_10", "reactive")))),
    Figure("claims: the replica's resonance under a 10 Hz held command",
           r"move (?P<fic>[\d.]+) times what it is told at (?P<f>[\d.]+) Hz \(quartiles "
           r"(?P<q25>[\d.]+)-(?P<q75>[\d.]+)\), "
           r"the linear laws' (?P<low>[\d.]+)-(?P<high>[\d.]+)",
           lambda: dict(fic=f"{peak_gain('fic')['peak_gain']:.2f}", f=f"{peak_gain('fic')['peak_frequency_hz']:.1f}",
                        q25=f"{quartiles_at_peak('fic')[0]:.2f}", q75=f"{quartiles_at_peak('fic')[1]:.2f}",
                        low=f"{min(peak_gain(law)['peak_gain'] for law in LINEAR_LAWS):.2f}",
                        high=f"{max(peak_gain(law)['peak_gain'] for law in LINEAR_LAWS):.2f}")),
    Figure("claims: the FIC's runs judged with the forced answer taken out",
           r"the FIC's runs of these cells are stable in (?P<off_1>\d+/\d+) and (?P<off_02>\d+/\d+) without the force "
           r"loop \(1 s and 0\.2 s; the earlier rule: (?P<old_off_1>\d+/\d+) and (?P<old_off_02>\d+/\d+)\) and in "
           r"(?P<on_1>\d+/\d+) and (?P<on_02>\d+/\d+) with it \((?P<old_on_1>\d+/\d+) and (?P<old_on_02>\d+/\d+)\), "
           r"and the verdict reports the resonance it took out: the FIC's arm moves (?P<gain>[\d.]+) times the "
           r"operator's planned offset at (?P<period>[\d.]+) s .{0,400}?; (?P<worse>\d+) runs the earlier rule passed "
           r"now fail so",
           lambda: dict(off_1=refit_k_n("delay_1__rate_10__feedback_off"),
                        off_02=refit_k_n("delay_0.2__rate_10__feedback_off"),
                        old_off_1=refit_k_n("delay_1__rate_10__feedback_off", "stable_without_fit"),
                        old_off_02=refit_k_n("delay_0.2__rate_10__feedback_off", "stable_without_fit"),
                        on_1=refit_k_n("delay_1__rate_10"), on_02=refit_k_n("delay_0.2__rate_10"),
                        old_on_1=refit_k_n("delay_1__rate_10", "stable_without_fit"),
                        old_on_02=refit_k_n("delay_0.2__rate_10", "stable_without_fit"),
                        gain=f"{refit('delay_1__rate_10__feedback_off')['resonance_gain_median']:.2f}",
                        period=f"{refit('delay_1__rate_10__feedback_off')['resonance_period_median_s']:.2f}",
                        worse=str(sum(1 for entry in result("verdict_forced_answer_claims.json")[
                            "by_cell_and_law"].values() for change in entry["changed"] if change["now"] is False)))),
    Figure("bench: free-motion error of the ten default runs",
           r"free-motion tracking error max (?P<max_low>[\d.]+)-(?P<max_high>[\d.]+) mm .{0,40}RMS "
           r"(?P<rms_low>[\d.]+)-(?P<rms_high>[\d.]+) mm",
           lambda: dict(zip(("max_low", "max_high"), (f"{v:.1f}" for v in result("bench.json")["default_summary"][
               "min_median_max"]["free_motion_error_max_mm"][::2])), **dict(zip(("rms_low", "rms_high"), (
                   f"{v:.1f}" for v in result("bench.json")["default_summary"]["min_median_max"][
                       "free_motion_error_rms_mm"][::2]))))),
    Figure("bench: latency and loop rates of the ten default runs",
           r"pipeline latency p99 (?P<p99_low>[\d.]+)-(?P<p99_high>[\d.]+) ms \(under 5 ms in (?P<under>\d+) of "
           r"(?P<runs>\d+); median (?P<p50_low>[\d.]+)-(?P<p50_high>[\d.]+) ms\), every loop at (?P<loop>[\d.]+) % of "
           r"its rate or more",
           lambda: dict(p99_low=f"{bench_range('pipeline_latency_p99_ms')[0]:.1f}",
                        p99_high=f"{bench_range('pipeline_latency_p99_ms')[1]:.1f}",
                        under=str(result("bench.json")["default_summary"]["met"]["latency p99 < 5 ms"]),
                        runs=str(result("bench.json")["default_summary"]["runs"]),
                        p50_low=f"{min(bench_runs('pipeline_latency_p50_ms')):.1f}",
                        p50_high=f"{max(bench_runs('pipeline_latency_p50_ms')):.1f}",
                        loop=f"{100 * bench_range('slowest_loop_fraction')[0]:.1f}")),
    Figure("closed-loop operator at 1 and 2 s: stable counts",
           r"at 1 s the FIC (?P<fic_1>\d)/5 against (?P<low_1>\d)-(?P<high_1>\d)/5, at 2 s the FIC and the passivity "
           r"baseline (?P<fic_2>\d)/5, the others (?P<others_2>\d)/5",
           lambda: dict(fic_1=stable_count(CLOSED_LOOP, "delay_1", "fic"),
                        low_1=str(min(cell(CLOSED_LOOP, "delay_1", c)["stable"] for c in BASELINES)),
                        high_1=str(max(cell(CLOSED_LOOP, "delay_1", c)["stable"] for c in BASELINES)),
                        fic_2=one_count(CLOSED_LOOP, "delay_2", ("fic", "linear_tdpa")),
                        others_2=one_count(CLOSED_LOOP, "delay_2", ("fic_paper_law", "linear", "linear_bounded")))),
    Figure("E1 lockstep: free-motion error and limit violations",
           r"The lockstep E1 run with the passive attractor: (?P<max>[\d.]+) mm and (?P<rms>[\d.]+) mm, "
           r"(?P<violations>\d+) limit-violation ticks",
           lambda: dict(max=mm(result("e1.json")["metrics"]["free_motion_error_max_m"]),
                        rms=mm(result("e1.json")["metrics"]["free_motion_error_rms_m"]),
                        violations=str(result("e1.json")["limits"]["violation_ticks"]))),
    Figure("10 Hz: the whole torque loop",
           r"the whole torque loop (?P<linear>\d)/5 for the unbounded linear law and (?P<low>\d)-(?P<high>\d)/5 for "
           r"every bounded law, the FIC (?P<fic>\d)/5",
           lambda: dict(linear=stable_count("evidence.json", "torque_loop_10", "linear"),
                        low=str(min(cell("evidence.json", "torque_loop_10", c)["stable"] for c in BOUNDED)),
                        high=str(max(cell("evidence.json", "torque_loop_10", c)["stable"] for c in BOUNDED)),
                        fic=stable_count("evidence.json", "torque_loop_10", "fic"))),
    Figure("10 Hz: only the law (gravity at the physics rate)",
           r"only the law at 10 Hz, the unbounded and bounded linear laws (?P<linear>\d)/5 and "
           r"(?P<bounded>\d)/5, the FIC, the paper's law and `linear_tdpa` (?P<fic>\d)/5",
           lambda: dict(linear=stable_count("evidence.json", "feedback_rate_10", "linear"),
                        bounded=stable_count("evidence.json", "feedback_rate_10", "linear_bounded"),
                        fic=one_count("evidence.json", "feedback_rate_10", ("fic", "fic_paper_law", "linear_tdpa")))),
    Figure("5 Hz: the FIC in both rate sweeps",
           r"at 5 Hz the FIC (?P<fic>\d)/5 in both",
           lambda: dict(fic=one_count("evidence.json", "feedback_rate_5", ("fic",), "torque_loop_5"))),
    Figure("closed-loop operator at 1 s: the FIC against the linear law",
           r"\(FIC (?P<fic_low>[\d.]+)-(?P<fic_high>[\d.]+) against linear (?P<lin_low>[\d.]+)-(?P<lin_high>[\d.]+) "
           r"at 1 s\)",
           lambda: dict(zip(("fic_low", "fic_high", "lin_low", "lin_high"), (f"{v:.2f}" for v in (
               *cell("evidence_closed_loop_5seeds.json", "delay_1", "fic")["stable_interval_95"],
               *cell("evidence_closed_loop_5seeds.json", "delay_1", "linear")["stable_interval_95"]))))),
    Figure("E2 graph, the replica's default law at 200 ms: trials complete and their interval",
           r"the FIC completes (?P<complete>\d+) of (?P<trials>\d+) graph trials \(Wilson "
           r"(?P<low>[\d.]+)-(?P<high>[\d.]+)\)",
           lambda: graph_trials("e2_graph_fic.jsonl", r"the FIC completes \d+ of (?P<trials>\d+) graph trials")),
    Figure("E2 graph, the replica's default law: pieces, their interval, peak forces",
           r"default law (?P<inside>\d+) of (?P<pieces>\d+) pieces \((?P<low>[\d.]+)-(?P<high>[\d.]+)\), .{0,30}?, "
           r"peak "
           r"(?P<peak_low>[\d.]+)-(?P<peak_high>[\d.]+) N",
           lambda: dict(inside=str(sum(len(t["pieces_inside"]) for t in jsonl("e2_graph_fic.jsonl"))),
                        pieces=str(3 * len(jsonl("e2_graph_fic.jsonl"))),
                        **interval(sum(len(t["pieces_inside"]) for t in jsonl("e2_graph_fic.jsonl")),
                                   3 * len(jsonl("e2_graph_fic.jsonl"))),
                        peak_low=f"{min(t['peak_force_n'] for t in jsonl('e2_graph_fic.jsonl')):.1f}",
                        peak_high=f"{max(t['peak_force_n'] for t in jsonl('e2_graph_fic.jsonl')):.1f}")),
    Figure("E2 graph, Eq. 7 as written at 200 ms: trials complete and their interval",
           r"Eq\. 7 as written (?P<complete>\d+) of (?P<trials>\d+) graph trials \((?P<low>[\d.]+)-(?P<high>[\d.]+)\)",
           lambda: graph_trials("e2_graph_stamped.jsonl", r"Eq\. 7 as written \d+ of (?P<trials>\d+) graph trials")),
    Figure("E2 graph, the unbounded linear law at 200 ms: trials complete and their interval",
           r"linear (?P<complete>\d+) of (?P<trials>\d+) graph trials \((?P<low>[\d.]+)-(?P<high>[\d.]+)\)",
           lambda: graph_trials("e2_graph_linear.jsonl", r"linear \d+ of (?P<trials>\d+) graph trials")),
    Figure("E2 in process at 200 ms, every law (the sweep grows: checked on the seeds the README counts)",
           r"at 200 ms: the default FIC (?P<fic>\d+ of \d+) \((?P<low>[\d.]+)-(?P<high>[\d.]+)\), as written "
           r"(?P<fic_paper_law>\d+ of \d+) \([\d.]+-[\d.]+\), linear (?P<linear>\d+ of \d+), linear_bounded "
           r"(?P<linear_bounded>\d+ of \d+), linear_tdpa (?P<linear_tdpa>\d+ of \d+)",
           lambda: e2_sweep_at_200ms()),
    Figure("E2 in process at 0, 0.5 and 1 s, every law, 10 seeds each",
           r"At 0, 0\.5 and 1 s \(10 seeds each\): the default FIC (?P<fic>\d+, \d+ and \d+) of 10, as written "
           r"(?P<fic_paper_law>\d+, \d+ and \d+), linear (?P<linear>\d+, \d+ and \d+), linear_bounded "
           r"(?P<linear_bounded>\d+, \d+ and \d+), linear_tdpa (?P<linear_tdpa>\d+, \d+ and \d+)",
           lambda: e2_sweep_other_delays()),
    Figure("E2 lockstep graph, scripted operator: trials complete",
           r"\((?P<complete>\d+) of (?P<trials>\d+) trials complete, 2026-12-02\)",
           lambda: dict(complete=str(result("e2.json")["successful_trials"]),
                        trials=str(len(result("e2.json")["trials"])))),
    Figure("E3: energy, limits, force and error after the loss",
           r"\((?P<before>[\d.]+) J peak before, (?P<after>[\d.]+) J after\), (?P<violations>\d+) limit violations, "
           r"peak force (?P<force>[\d.]+) N, error at most (?P<error>[\d.]+) mm",
           lambda: dict(before=f"{result('e3.json')['blackout']['energy_max_before_j']:.3f}",
                        after=f"{result('e3.json')['blackout']['energy_max_after_j']:.3f}",
                        violations=str(result("e3.json")["blackout"]["violation_ticks_after"]),
                        force=f"{result('e3.json')['blackout']['peak_force_after_n']:.1f}",
                        error=mm(result("e3.json")["blackout"]["error_max_after_m"]))),
]


@pytest.mark.parametrize("figure", FIGURES, ids=[figure.name for figure in FIGURES])
def test_readme_figure_matches_its_json(figure: Figure):
    found = list(re.finditer(figure.pattern, readme_results()))
    assert len(found) == 1, f"README's Results section should say this once: {figure.pattern}"
    assert found[0].groupdict() == figure.expected()


def test_the_checks_fail_on_a_wrong_figure():
    """The machinery itself: a README figure one digit off does not match its JSON."""
    figure = next(f for f in FIGURES if f.name.startswith("E1 lockstep"))
    written = re.search(figure.pattern, readme_results()).groupdict()
    wrong = {**written, "max": f"{float(written['max']) + 0.1:.1f}"}
    assert wrong != figure.expected()


# -- the claim sweep: README's generated block and the statistics behind it ---------------------------------------
CLAIMS_BEGIN, CLAIMS_END = "<!-- claims: begin", "<!-- claims: end -->"


def test_readme_claims_block_is_generated_from_the_statistics():
    """README's block on the FIC papers' claims is claims_report's from results/claims_statistics.json, to the
    character (a figure changed by hand, or statistics regenerated without README, fails here)."""
    from fic_teleop_experiments.tables import readme_claims

    text = (REPO / "README.md").read_text()
    assert text.count(CLAIMS_BEGIN) == 1 and text.count(CLAIMS_END) == 1, "README's Results hold one claims block"
    start = text.index("\n", text.index(CLAIMS_BEGIN)) + 1
    assert text[start:text.index(CLAIMS_END, start)] == readme_claims(result("claims_statistics.json")), (
        "regenerate: python -m fic_teleop_experiments.claims_report --readme results/claims_statistics.json")


def test_claims_statistics_are_those_of_the_judged_sweep():
    """results/claims_statistics.json recomputed from results/claims.json (every run with both verdicts)."""
    from fic_teleop_experiments.claims_report import claims_statistics, read_runs

    written = result("claims_statistics.json")
    again = json.loads(json.dumps(claims_statistics(read_runs(REPO / "results" / "claims.json"),
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
