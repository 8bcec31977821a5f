"""The claim cells: the FIC papers' "1 s delay" and "10 Hz bandwidth" as they state them (docs/EXPERIMENTS.md "Claims").

What the earlier FIC teleoperation work claims is stability with a fixed one-way delay of up to 1 s and a
communication rate as low as 10 Hz, with the robot's torque loop and the law at 1 kHz: the master->replica command
and the force feedback are each sample-and-held between the link's deliveries. So a claim cell here is:

- both channel directions at one rate (full, 10 or 5 Hz): the channel's rate cap delivers the newest due message at
  that rate and the receiver holds it until the next (sim_bridge.channel.channel), the command forward and F_R back;
- one fixed delay each way (0, 0.2, 1 or 2 s, and the delay sweep's 0.5 and 1.5 s at full rate);
- the replica's law and the robot at 1 kHz (the in-process runner, every joint state answered);
- the closed-loop operator timing its moves from the delayed video, feeling F_R through the handle (force feedback
  on: the master's K_H), with a passive hand (the optimistic operator) or the force-reactive hand;
- a task that does not repeat: per seed the planner's laps and the operator's moves and wander are drawn
  (in_process.TASK_*, MOVE_*, WANDER_* ranges), in the paper's superimposition scene with both obstacles;
- every law of ``CONTROLLERS``, the same seeds for every law and hand (paired);
- a quiet tail after the task (``tail_for``): the planner's trajectory stops, the operator's target holds still, the
  hand keeps holding the handle and the link keeps running, so that the run ends with the loop's free response, which
  the run verdict judges stability by (docs/EXPERIMENTS.md, "The run verdict"). Its start is in the kept series
  (RunResult.quiet_from).

Control cells (``force_feedback=False``, the cell's name ends in ``__feedback_off``): the same runs with the master's
haptic gain K_H = 0 (paper Eq. 3), so no force loop closes through the channel: the hand feels the handle's own
centring spring alone and the replica follows the command the hand and handle make (the operator still times its
moves from the delayed video, a sampled loop of one decision a move). The bilateral force loop whose delay the
claims are about is open, so an oscillation the verdict finds there is the operator's own or the replica's answer
to it; read beside the claim cell with feedback on, it tells what the closed loop adds (docs/EXPERIMENTS.md
"Claims", "Open-loop controls").

A run is one ``ClaimRun``; ``execute`` simulates it, keeps its series (``save_series``: every per-sample field of the
RunResult at ``SERIES_RATE_HZ``, float32, and its scalars) and returns one JSON-ready row of figures. The verdict is
applied to the kept series afterwards (``judge_series``), so a changed verdict never needs a new simulation.
"""
from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import time as wall_clock
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from fic_teleop_experiments.in_process import HANDS, RunConfig, RunResult, run
from fic_teleop_experiments.seed_jitter import CHANNEL_JITTER_S, HAND_IMPEDANCE_JITTER, OPERATOR_TIMING_JITTER_S

#: The laws compared: the replica's own, and the FIC as the paper writes it (Eq. 7 + posture + postural
#: optimisation, without the feedforward and friction terms: the replica's paper_law), the linear baselines, and
#: the bounded one made passive at the channel's ports by time-domain passivity (in_process: linear_tdpa).
CONTROLLERS = ("fic", "fic_paper_law", "linear", "linear_bounded", "linear_tdpa")

#: One-way delays [s] and channel rates [Hz] (0: full rate, the 100 Hz network stream undelayed by any cap).
CLAIM_DELAYS_S = (0.0, 0.2, 1.0, 2.0)
CLAIM_RATES_HZ = (0.0, 10.0, 5.0)
#: The delay sweep at full rate adds these to the claim delays.
SWEEP_EXTRA_DELAYS_S = (0.5, 1.5)
SEEDS = 20
#: The open-loop control cells (delay, rate): the two claim cells at 10 Hz, the force-reactive hand.
CONTROL_CELLS = ((1.0, 10.0), (0.2, 10.0))
CONTROL_HANDS = ("reactive",)
#: Kept series rate [Hz]: the replica's 100 Hz poses every second sample. The verdict's shortest period (0.2 s) is
#: 10 samples; peaks (error, force) are taken from the full-rate run into the row before the series is thinned.
SERIES_RATE_HZ = 50.0
#: The figures' start-up left out [s] (the robot reaching the circle).
SETTLE_S = 2.0


def duration_for(delay: float) -> float:
    """The task's length [s]: 30 s, longer beyond 1 s of delay so that the span after start-up holds 1.5 periods of 4
    round trips at 1.5 s (37.5 s) and most of one at 2 s (45 s). The quiet tail comes after it (``tail_for``)."""
    return 30.0 + 15.0 * max(0.0, delay - 1.0)


def tail_for(delay: float) -> float:
    """The quiet tail's length [s]: the least the run verdict judges (VerdictCriterion.tail_needed): one round trip
    and 1 s while the last input leaves the loop (the operator's last target reaches the replica one delay later, its
    answer comes back another delay later; the planner stops within 0.8 s), then 4 round trips, at least 8 s. A
    delay-induced oscillation has a period of at most about 4 round trips (its phase lag of pi/2 to pi accrues over
    one round trip), so the judged part holds one period of the slowest of them and its energy peaks twice; 8 s holds
    several periods of the arm's and the hand's own modes (0.5-3 s) when the delay is short."""
    from fic_teleop_tools.verdict.run_verdict import VerdictCriterion

    return VerdictCriterion().tail_needed(delay)


@dataclass(frozen=True)
class ClaimRun:
    delay: float          # [s] one way
    rate_hz: float        # [Hz] both directions (0: full rate)
    controller: str       # CONTROLLERS
    hand: str             # in_process.HANDS
    seed: int
    duration: float       # [s] the task
    force_feedback: bool = True   # False: the master's K_H = 0, an open-loop control run (module docstring)
    tail: float = 0.0     # [s] the quiet tail after the task (``tail_for``; 0: none, the runs kept before it)

    def __post_init__(self) -> None:
        if self.controller not in CONTROLLERS:
            raise ValueError(f"controller must be one of {CONTROLLERS}, got {self.controller!r}")
        if self.hand not in HANDS:
            raise ValueError(f"hand must be one of {HANDS}, got {self.hand!r}")
        if not (math.isfinite(self.delay) and self.delay >= 0.0 and math.isfinite(self.rate_hz)
                and self.rate_hz >= 0.0 and self.duration > 0.0 and math.isfinite(self.tail) and self.tail >= 0.0):
            raise ValueError(f"delay, rate and tail must be finite and >= 0, duration > 0: {self}")

    @property
    def cell(self) -> str:
        return (f"delay_{self.delay:g}__rate_{'full' if self.rate_hz == 0.0 else f'{self.rate_hz:g}'}"
                + ("" if self.force_feedback else "__feedback_off"))

    @property
    def key(self) -> str:
        """The run's name (its series file's stem, the JSON line's key)."""
        return (f"{self.cell}__{self.controller}__{self.hand}__{self.seed}__{self.duration:g}s"
                + (f"__tail_{self.tail:g}s" if self.tail > 0.0 else ""))

    def config(self) -> RunConfig:
        paper_law = self.controller == "fic_paper_law"
        return RunConfig(scene="superimposition", duration=self.duration + self.tail,
                         quiet_from=self.duration if self.tail > 0.0 else None, delay=self.delay, rate_cap=self.rate_hz,
                         tail_clear=tail_for(self.delay) if self.tail > 0.0 else 0.0,
                         controller="fic" if paper_law else self.controller,
                         replica_overrides={"paper_law": True} if paper_law else {},
                         master_overrides={} if self.force_feedback else {"haptic_gain": 0.0},
                         seed=self.seed, operator="closed_loop", hand=self.hand, task_variation=True,
                         jitter=CHANNEL_JITTER_S, operator_timing_jitter=OPERATOR_TIMING_JITTER_S,
                         hand_impedance_jitter=HAND_IMPEDANCE_JITTER)


def claim_cells(quick: bool = False) -> list[tuple[int, float, float]]:
    """(tier, delay, rate) in the order they are run: tier 1 the cells the FIC papers' claim and the goals are about
    (1 s, 0.2 s and no delay, each at 10 Hz and at full rate), tier 2 the same delays at 5 Hz, tier 3 the 2 s row and
    the delay sweep's extra delays at full rate. The cells of ``dense_cell`` get twice the seeds, right after tier 1;
    the open-loop controls (CONTROL_CELLS) come last (``claim_runs``)."""
    if quick:
        return [(1, 1.0, 10.0), (1, 1.0, 0.0)]
    first = [(1, 1.0, 10.0), (1, 1.0, 0.0), (1, 0.2, 10.0), (1, 0.2, 0.0), (1, 0.0, 10.0), (1, 0.0, 0.0)]
    second = [(2, 1.0, 5.0), (2, 0.2, 5.0), (2, 0.0, 5.0)]
    third = [(3, 2.0, 10.0), (3, 2.0, 0.0), (3, 2.0, 5.0)] + [(3, delay, 0.0) for delay in SWEEP_EXTRA_DELAYS_S]
    return first + second + third


def dense_cell(delay: float, rate_hz: float) -> bool:
    """The cells at 1 s or less with the link at 10 Hz, where the laws' stable shares were closest: twice the seeds,
    so a difference of 0.10 between two laws is not lost in a Wilson interval of 20 runs."""
    return delay <= 1.0 and rate_hz == 10.0


def claim_runs(seeds: int = SEEDS, controllers: Iterable[str] = CONTROLLERS, hands: Iterable[str] = HANDS,
               quick: bool = False, duration: float | None = None, controls: bool = True,
               tail: bool = True) -> list[ClaimRun]:
    """Every run, most important first: by tier; within a tier seed by seed over its cells, every law and hand at a
    seed together (an interrupted sweep leaves paired, comparable runs); then the open-loop controls (not with
    ``quick``), the same seeds and laws. ``duration``: the task's length (default ``duration_for``); each run ends
    with its quiet tail (``tail_for``) unless ``tail`` is False."""
    controllers, hands = tuple(controllers), tuple(hands)
    cells = claim_cells(quick)
    out = []

    def length(delay: float) -> float:
        return duration if duration is not None else duration_for(delay)

    def add(delay: float, rate: float, seed: int) -> None:
        for controller in controllers:
            for hand in hands:
                out.append(ClaimRun(delay, rate, controller, hand, seed, length(delay),
                                    tail=tail_for(delay) if tail else 0.0))

    for tier in sorted({c[0] for c in cells}):
        for seed in range(1, seeds + 1):
            for _, delay, rate in (c for c in cells if c[0] == tier):
                add(delay, rate, seed)
        if tier == 1 and not quick:   # the dense cells' second set of seeds, before the rest of the grid
            for seed in range(seeds + 1, 2 * seeds + 1):
                for _, delay, rate in (c for c in cells if c[0] == tier and dense_cell(c[1], c[2])):
                    add(delay, rate, seed)
    if controls and not quick:
        for seed in range(1, seeds + 1):
            for delay, rate in CONTROL_CELLS:
                for controller in controllers:
                    for hand in (h for h in hands if h in CONTROL_HANDS):
                        out.append(ClaimRun(delay, rate, controller, hand, seed, length(delay), force_feedback=False,
                                            tail=tail_for(delay) if tail else 0.0))
    return out


# -- series ----------------------------------------------------------------------------------------------------------
def _per_sample_fields(result: RunResult) -> list[str]:
    n = len(result.time)
    return [f.name for f in dataclasses.fields(result)
            if isinstance(getattr(result, f.name), np.ndarray) and getattr(result, f.name).ndim >= 1
            and len(getattr(result, f.name)) == n]


def _scalar_fields(result: RunResult) -> list[str]:
    return [f.name for f in dataclasses.fields(result)
            if isinstance(getattr(result, f.name), (int, float, np.integer, np.floating))
            and not isinstance(getattr(result, f.name), bool)]


#: Per-sample series whose events a stride would drop, pooled over each kept sample's block instead (``thinned``).
POOLED_PEAK_FIELDS = ("force",)


def thinned(result: RunResult, rate_hz: float = SERIES_RATE_HZ) -> RunResult:
    """The result with every per-sample series at ``rate_hz``: every k-th sample of the motions and energies, and
    over each block of k samples (the kept one and those up to the next) any true of a flag and the largest-magnitude
    sample of the force.

    Why pooled: a touch of the fixed obstacle lasting one 100 Hz sample fell between the kept samples half the time,
    flag and force spike both. The verdict then saw no contact and judged the channel's burst one delay later (the
    10 Hz link holds the spike's sample for 100 ms at the handle) as steady generation outside contact: a run judged
    stable on its full-rate series was judged unstable on its kept one (docs/EXPERIMENTS.md, "Claims")."""
    n = len(result.time)
    step = float(np.median(np.diff(result.time))) if n > 1 else 1.0 / rate_hz
    every = max(1, int(round(1.0 / (rate_hz * step))))
    if every == 1 or n == 0:
        return result
    starts = np.arange(0, n, every)

    def kept(name: str) -> np.ndarray:
        values = getattr(result, name)
        if values.dtype == bool:
            return np.logical_or.reduceat(values, starts, axis=0)
        if name in POOLED_PEAK_FIELDS:
            magnitude = np.full(starts.size * every, -np.inf)
            magnitude[:n] = np.linalg.norm(np.nan_to_num(values.reshape(n, -1), nan=np.inf), axis=1)
            return values[starts + magnitude.reshape(starts.size, every).argmax(axis=1)]
        return values[::every]

    return dataclasses.replace(result, **{name: kept(name) for name in _per_sample_fields(result)})


def save_series(path: Path, result: RunResult) -> None:
    """Per-sample series (float32 but the time, booleans kept), scalars, and the draws and moves as JSON."""
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {}
    for name in _per_sample_fields(result):
        values = getattr(result, name)
        arrays[name] = values if name == "time" or values.dtype == bool else values.astype(np.float32)
    scalars = {name: np.asarray(getattr(result, name)) for name in _scalar_fields(result)}
    extra = json.dumps({"draws": result.draws, "operator_moves": result.operator_moves})
    temporary = path.with_name(path.name + ".partial.npz")
    np.savez_compressed(temporary, **arrays, **scalars, extra_json=np.asarray(extra))
    temporary.replace(path)   # a run killed while writing leaves no half file under the run's name


def load_series(path: Path) -> RunResult:
    """A RunResult from ``save_series`` (float64 again; the scene's objects are not kept)."""
    names = {f.name for f in dataclasses.fields(RunResult)}
    with np.load(path) as data:
        values: dict[str, Any] = {}
        for name in data.files:
            if name == "extra_json":
                values.update(json.loads(str(data[name])))
            elif name in names:
                array = data[name]
                values[name] = array.item() if array.ndim == 0 else (
                    array if array.dtype == bool else array.astype(np.float64))
    values["operator_moves"] = [tuple(move) for move in values.get("operator_moves", [])]
    return RunResult(objects={}, **values)


# -- one run -----------------------------------------------------------------------------------------------------------
def figures(claim: ClaimRun, result: RunResult) -> dict[str, Any]:
    """The row's figures, from the full-rate result, over the task: after the start-up (after half the task if that is
    shorter) and before the quiet tail (the tail is the verdict's; a tracking error averaged over it would flatter a
    law by the tail's length)."""
    if result.quiet_from is None:
        task = np.ones(result.time.size, dtype=bool)
        end = float(result.time[-1])
    else:
        task, end = result.time < result.quiet_from, float(result.quiet_from)
    after = (result.time >= min(SETTLE_S, 0.5 * end)) & task
    error = result.tracking_error[after]
    force = np.linalg.norm(result.force, axis=1)
    free = force < 1.0
    step = float(np.median(np.diff(result.time)))
    ports = result.port_energy
    return dict(error_rms_m=float(np.sqrt(np.mean(error ** 2))), error_max_m=float(error.max()),
                error_free_p95_m=float(np.percentile(result.tracking_error[after & free], 95))
                if np.any(after & free) else None,
                peak_force_n=float(force[after].max()), limit_violations=int(result.limit_violations),
                shaped_ticks=int(result.shaped_ticks), passivity_violation_ticks=int(result.passivity_violation_ticks),
                channel_generated_j=float(ports[-1, 2]) if ports is not None and len(ports) else None,
                joint_speed_max=float(getattr(result, "joint_speed_max", 0.0)),
                robot_watchdog_engagements=int(getattr(result, "robot_watchdog_engagements", 0)),
                stale_torques_refused=int(getattr(result, "stale_torques_refused", 0)),
                replica_holds=int(getattr(result, "replica_holds", 0)),
                fixed_obstacle_contact_s=float(np.sum(result.obstacle_contact[after]) * step)
                if result.obstacle_contact is not None else None,
                operator_moves=len(result.operator_moves))


def execute(claim: ClaimRun, directory: str | Path, provenance: dict[str, Any] | None = None) -> dict[str, Any]:
    """Simulate one run, keep its series under ``directory`` (``<key>.npz``) and return its JSON row."""
    started = wall_clock.time()
    result = run(claim.config())
    path = Path(directory) / f"{claim.key}.npz"
    save_series(path, thinned(result))
    return dict(key=claim.key, cell=claim.cell, **dataclasses.asdict(claim), wall_s=result.wall_s,
                wall_total_s=wall_clock.time() - started, simulated_s=result.simulated_s, started_at=started,
                series=path.name, series_rate_hz=SERIES_RATE_HZ, draws=result.draws,
                operator_time_shift_s=result.operator_time_shift, hand_scale=result.hand_scale,
                figures=figures(claim, result), **(provenance or {}))


#: run_verdict figures kept with each judged run in results/claims.json.
VERDICT_FIGURES = ("channel_generation_rate_w", "channel_generation_rate_all_w", "channel_generation_free_s",
                   "contact_share", "excluded_share", "energy_growth", "free_error_max_m", "resonance_gain",
                   "resonance_period_s", "swing_m", "swing_period_s", "quiet_from_s", "tail_motion_max_m",
                   "tail_motion_ratio", "tail_energy_ratio", "tail_free_from_s")


def judge_series(path: Path, delay: float) -> dict[str, Any]:
    """The run verdict (fic_teleop_tools.verdict.run_verdict) on a kept series: stable, safe and their reasons."""
    from fic_teleop_tools.verdict.run_verdict import VerdictInput, judge

    verdict = judge(VerdictInput.from_run_result(load_series(path), one_way_delay=delay))
    # The figures a reader checks a verdict against (the rest are recomputed from the series in a second).
    kept = {name: verdict.figures.get(name) for name in VERDICT_FIGURES}
    return dict(stable=verdict.stable, safe=verdict.safe, stable_reasons=verdict.stable_reasons,
                safe_reasons=verdict.safe_reasons, notes=verdict.notes, figures=kept)


def provenance(repository: Path) -> dict[str, Any]:
    """The commit the code ran from, and whether its tracked files differed from it."""
    def git(*args: str) -> str:
        try:
            return subprocess.run(["git", "-C", str(repository), *args], capture_output=True, text=True,
                                  check=True).stdout.strip()
        except (OSError, subprocess.CalledProcessError):
            return ""
    if (repository / "COMMIT").exists():   # a snapshot of one commit (scripts/claims_background.sh)
        return dict(commit=(repository / "COMMIT").read_text().strip(), tree_modified=False)
    commit = git("rev-parse", "HEAD")
    return dict(commit=commit or None, tree_modified=bool(git("status", "--porcelain", "--untracked-files=no")))
