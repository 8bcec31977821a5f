"""Whether the computer kept real time during a run: the launcher's last word after the safety figures.

On a loaded machine the graph falls behind the wall clock and the arm tracks worse, and a run that only reported
its error looked like a worse controller (a fresh clone's run at RTF 0.75: error 181 / 51 mm, exit 0). So after
every realtime run the launcher states four figures against their bounds and says "the machine was starved"
when one is out, with its own exit code (EXIT_STARVED, docs/SECURITY.md "Exit codes of the launcher"). The bounds
are the run profile's ``timing_bounds`` (fic_teleop_bringup/profiles/realtime.yaml, where each is explained):

- the real-time factor (the report's, after its warm-up) at least ``real_time_factor``: the report's own target
  (fic_teleop_tools/report/metrics.py TARGETS) unless a profile sets it, and then the launcher hands it to the
  report too, so that the report's table and this verdict judge by one bound;
- every loop's achieved rate (fic_teleop_tools/report/loop_rates.py) at least ``loop_rate_fraction`` of its nominal
  rate; a loop with no message at all is not this graph's (or its node failed, which the safety verdict reports);
- the part of the run's window the bag holds at least ``recorded_fraction`` of that window: a starved recorder
  keeps only part of the run. The window is the launcher's ``--duration`` on the simulation's clock (from the first
  /clock at or after the script's start to the last /clock it saw, `SimulatedWindow`), and the bag's part of it is
  read on the same clock, from the bag's own /clock stamps (`recorded_in_window`). Not the bag's whole span: the
  recorder starts with the graph, before the start margin, so a 6 s run's bag spans about 10 s of simulated time;
- the replica's own loop (its "replica loop health" record on /diagnostics): no hold in the run's window, i.e. no
  control tick on a state older, or after a gap longer, than the replica's bounds (loop_max_state_age,
  loop_max_tick_gap) once the operator's script has started. Its largest state age and tick gap are reported with
  it, and every hold is counted. A hold before the window (`holds_before_window`: the holds of the last record the
  bag received before the window's first /clock) came while the other processes were still starting, with the arm
  at rest and held before the operator's start: it touches none of the run's figures, which are all judged in the
  window (2026-12-07: every hold that made a quiet run exit 6 came 64-340 ms after the replica's first joint
  state). It is named, not a reason. A bag without the record: the figure is unknown, not a pass; without a record
  before the window every hold counts as in it.

A realtime run with none of these figures (no bag streams to measure them) is not shown to have kept real time,
and gets the starved code too.

Lockstep runs are not judged: the simulation waits for every answer, so no figure of theirs says the computer
was too slow for the arm.
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from fic_teleop_bringup.launch_supervision import SAFETY_RECORDS
from fic_teleop_bringup.run_bag import RunBag, scan
from fic_teleop_tools.report.metrics import TARGETS as REPORT_TARGETS

LOOP_HEALTH_STATUS = "replica loop health"   # fic_core/loop_health.py diagnostic_values, as the replica names it
LOOP_HEALTH_KEY = "holds"
#: The /diagnostics records the launcher's two verdicts read (run_bag.scan reads them in its one pass).
JUDGED_RECORDS = {**SAFETY_RECORDS, LOOP_HEALTH_STATUS: LOOP_HEALTH_KEY}


def judged_topics(run_dir: Path) -> set[str]:
    """The streams whose receive times the timing verdict needs: those of the run's loops."""
    from fic_teleop_tools.report.loop_rates import loop_topics

    return loop_topics(run_dir)


@dataclass(frozen=True)
class TimingBounds:
    """The run profile's ``timing_bounds``: the least real-time factor, loop-rate share and recorded share."""
    real_time_factor: float
    loop_rate_fraction: float
    recorded_fraction: float

    @classmethod
    def from_profile(cls, profile: dict) -> "TimingBounds":
        """The profile's bounds; without its own ``real_time_factor``, the report's target (one value in one place:
        fic_teleop_tools/report/metrics.py TARGETS, which the report also judges a bag recorded without us by)."""
        bounds = dict(profile["timing_bounds"])
        bounds.setdefault("real_time_factor", REPORT_TARGETS["real_time_factor"][1])
        return cls(**bounds)


@dataclass(frozen=True)
class SimulatedWindow:
    """The run's ``--duration`` as the launcher counted it, on the simulation's clock [s]: from the first /clock at or
    after the script's start to the last /clock it saw."""
    start_s: float
    end_s: float

    @property
    def length_s(self) -> float:
        return max(self.end_s - self.start_s, 0.0)


def recorded_in_window(clock_stamps: np.ndarray, window: SimulatedWindow) -> float:
    """Seconds of ``window`` the bag holds: from its first /clock stamp inside the window to its last (both clocks are
    the simulation's, so a bag that also holds the start margin and the shutdown holds exactly the window)."""
    stamps = np.asarray(clock_stamps, dtype=float)
    inside = stamps[(stamps >= window.start_s) & (stamps <= window.end_s)]
    return float(inside.max() - inside.min()) if len(inside) else 0.0


@dataclass
class Timing:
    """The verdict: ``starved`` with one reason per figure out of bounds; ``figures`` as measured (None: unknown)."""
    judged: bool
    bounds: TimingBounds | None = None
    starved: bool = False
    reasons: list[str] = field(default_factory=list)
    figures: dict = field(default_factory=dict)

    def lines(self) -> list[str]:
        """What the launcher prints, one line per figure and the verdict."""
        if not self.judged:
            return ["lockstep: the simulation waits for every answer, real time is not judged"]
        f, bounds = self.figures, self.bounds
        rtf = f.get("real_time_factor")
        lines = [f"real-time factor {_show(rtf, '.3f')} (bound >= {bounds.real_time_factor:g})"]
        slowest = f.get("slowest_loop")
        lines.append(f"slowest loop {slowest} at {_show(f.get('slowest_loop_fraction'), '.3f')} of its rate "
                     f"(bound >= {bounds.loop_rate_fraction:g})" if slowest else "loop rates: none measured")
        if f.get("recorded_s") is not None:
            lines.append(f"the bag holds {f['recorded_s']:.1f} s of the run's {f['simulated_s']:.1f} s simulated "
                         f"(bound >= {bounds.recorded_fraction:.0%})")
        before = f.get("loop_holds_before_window") or 0
        lines.append(f"replica loop: {_show(f.get('loop_holds'), 'd')} holds"
                     + (f" ({before} before the operator's start, the arm at rest)" if before else "")
                     + f", state age max {_show(f.get('max_state_age_ms'), '.1f')} ms, tick gap max "
                     f"{_show(f.get('max_tick_gap_ms'), '.1f')} ms (bound: no hold in the run's window)"
                     if f.get("loop_holds") is not None else
                     "replica loop: no loop-health record in the bag (state age not known)")
        if f.get("killed_at_stop"):
            lines.append(f"killed at the stop, still running long after SIGINT: {', '.join(f['killed_at_stop'])}"
                         + (" (starved, not crashed)" if self.starved else ""))
        lines.append("STARVED: the machine did not keep real time, so the run's tracking figures are the computer's "
                     "as much as the controller's: " + "; ".join(self.reasons) if self.starved
                     else "the computer kept real time")
        return lines

    @property
    def measured(self) -> bool:
        """Whether any timing figure was measured (a real-time factor, a loop rate or a loop-health record)."""
        f = self.figures
        return f.get("real_time_factor") is not None or bool(f.get("slowest_loop")) or f.get("loop_holds") is not None


def _show(value, spec: str) -> str:
    return "n/a" if value is None else format(value, spec)


def timing_verdict(metrics: dict | None, rates: dict[str, dict], health: dict[str, str] | None,
                   bounds: TimingBounds, realtime: bool = True, recorded_s: float | None = None,
                   simulated_s: float | None = None, holds_before: int = 0, asked_s: float | None = None) -> Timing:
    """The verdict from the report's metrics.json, the loop rates, the replica's last loop-health record and the
    bag's share of the run (``recorded_s`` of the ``simulated_s`` the launcher counted, `recorded_in_window`),
    against the run profile's ``bounds``; ``holds_before``: the replica's holds before the run's window
    (`holds_before_window`); ``asked_s``: the run's --duration when it was not cut short by the user (None: not
    judged), of which the simulation must have run ``recorded_fraction`` (a simulation that never advanced leaves no
    other figure to judge: the wall-clock limit ends such a run)."""
    if not realtime:
        return Timing(judged=False)
    timing = Timing(judged=True, bounds=bounds)
    if asked_s and (simulated_s or 0.0) < bounds.recorded_fraction * asked_s:
        timing.reasons.append(f"the simulation ran {simulated_s or 0.0:.1f} s of the {asked_s:g} s asked")
    rtf = (metrics or {}).get("real_time_factor")
    timing.figures["real_time_factor"] = rtf
    if rtf is not None and rtf < bounds.real_time_factor:
        timing.reasons.append(f"real-time factor {rtf:.3f} < {bounds.real_time_factor:g}")
    if recorded_s is not None and simulated_s:
        timing.figures.update(recorded_s=round(recorded_s, 3), simulated_s=round(simulated_s, 3))
        if recorded_s < bounds.recorded_fraction * simulated_s:
            timing.reasons.append(f"the bag holds {recorded_s:.1f} s of the run's {simulated_s:.1f} s simulated (the "
                                  "recorder fell behind)")
    running = {name: row for name, row in rates.items()
               if row.get("fraction") is not None and math.isfinite(row["fraction"]) and row["achieved_hz"] > 0}
    if running:
        name = min(running, key=lambda loop: running[loop]["fraction"])
        row = running[name]
        timing.figures.update(slowest_loop=name, slowest_loop_fraction=row["fraction"],
                              loop_fractions={loop: r["fraction"] for loop, r in running.items()})
        slow = [f"{loop} {r['achieved_hz']:g} of {r['nominal_hz']:g} Hz" for loop, r in running.items()
                if r["fraction"] < bounds.loop_rate_fraction]
        if slow:
            timing.reasons.append(f"loops below {bounds.loop_rate_fraction:.0%} of their rate: {', '.join(slow)}")
    if health and LOOP_HEALTH_KEY in health:
        holds = int(health[LOOP_HEALTH_KEY])
        before = min(max(holds_before, 0), holds)
        timing.figures.update(loop_holds=holds, loop_holds_before_window=before,
                              held_ticks=_integer(health.get("held_ticks")),
                              max_state_age_ms=_float(health.get("max_state_age_ms")),
                              max_tick_gap_ms=_float(health.get("max_tick_gap_ms")))
        if holds > before:
            timing.reasons.append(f"the replica held the arm {holds - before} times in the run's window on its own "
                                  f"loop's bounds (the last: {health.get('last_hold_reason', 'not recorded')})")
    if not timing.measured:
        # Nothing to show the run kept real time: a recorder starved before it wrote the replica's streams, or a
        # replica that never ticked. Measured: such runs under a 50 % CPU quota exited 0 before this line.
        timing.reasons.append("no timing figure could be measured (no real-time factor, no loop rate, no "
                              "loop-health record in the bag)")
    timing.starved = bool(timing.reasons)
    return timing


def exit_code(safety_code: int, timing: Timing, starved_code: int) -> int:
    """The launcher's code: a broken safety figure (any non-zero ``safety_code``) wins; else ``starved_code`` when the
    machine was starved; else 0."""
    if safety_code:
        return safety_code
    return starved_code if timing.starved else 0


def _float(text: str | None) -> float | None:
    try:
        return float(text) if text is not None else None
    except ValueError:
        return None


def _integer(text: str | None) -> int | None:
    value = _float(text)
    return int(value) if value is not None else None


def holds_before_window(scanned: RunBag, window: SimulatedWindow) -> int:
    """The replica's holds before ``window``: those of the last "replica loop health" record the bag received before
    the window's first /clock (0 without one: every hold then counts as in the window)."""
    stamps, times = np.asarray(scanned.clock_stamps), np.asarray(scanned.clock_receive_times)
    inside = np.flatnonzero(stamps >= window.start_s) if len(stamps) == len(times) else np.empty(0, dtype=int)
    if not len(inside):
        return 0
    opened = int(times[inside[0]])
    before = [values for received, values in scanned.history.get(LOOP_HEALTH_STATUS, []) if received < opened]
    if not before:
        return 0
    return _integer(before[-1].get(LOOP_HEALTH_KEY)) or 0


def judge_run(run_dir: Path, bag: Path, metrics: dict | None, bounds: TimingBounds, realtime: bool,
              window: SimulatedWindow | None = None, killed_at_stop: list[str] | None = None,
              scanned: "RunBag | None" = None, asked_s: float | None = None) -> Timing:
    """The verdict of a finished run (its bag and report) against the profile's ``bounds``, also written to
    ``run_dir``/timing.json. ``window``: the run's duration as the launcher counted it (None: not known);
    ``killed_at_stop``: the nodes the launcher had to kill at the stop, named with the verdict (not a reason: a kill
    alone does not show that the machine was starved); ``scanned``: the bag as run_bag.scan read it for
    ``judged_topics`` and ``JUDGED_RECORDS`` (None: read here); ``asked_s``: as for ``timing_verdict``."""
    rates: dict[str, dict] = {}
    health = None
    recorded_s = None
    holds_before = 0
    if realtime and bag.exists():
        from fic_teleop_tools.report.loop_rates import loop_rates
        try:
            scanned = scanned if scanned is not None else scan(bag, judged_topics(run_dir), JUDGED_RECORDS)
            rates = loop_rates(bag, run_dir, receive_times=(scanned.receive_times, scanned.span))
        except Exception as error:  # noqa: BLE001 - a torn bag: the verdict goes on without the rates
            print(f"[run] timing: loop rates not measured ({error})")
        if scanned is not None:
            health = scanned.diagnostics.get(LOOP_HEALTH_STATUS)
            if window is not None and window.length_s > 0:
                recorded_s = recorded_in_window(scanned.clock_stamps, window)
                holds_before = holds_before_window(scanned, window)
    timing = timing_verdict(metrics, rates, health, bounds, realtime, recorded_s,
                            window.length_s if window is not None else None, holds_before, asked_s)
    if killed_at_stop and timing.judged:
        timing.figures["killed_at_stop"] = list(killed_at_stop)
    (run_dir / "timing.json").write_text(json.dumps(asdict(timing), indent=2) + "\n")
    return timing
