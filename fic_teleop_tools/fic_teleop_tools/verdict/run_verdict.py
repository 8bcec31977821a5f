"""Two verdicts per run, STABLE and SAFE, each with its reasons (docs/EXPERIMENTS.md, "The run verdict").

STABLE is judged by the loop's FREE RESPONSE when the run ends with a quiet tail (``VerdictInput.quiet_from``: the
planner's trajectory stopped, the operator's target still, the hand still holding the handle, the link running; every
claim run has one). A loop that is unstable keeps moving with no input; a stable loop's driven swing stops when the
input stops. So the verdict does not have to tell a stable loop's answer to its input from an oscillation of its own
while the input moves, which no test on the task alone does reliably (a resonant loop's forced swing and a limit
cycle look alike there). STABLE (None when the run or its tail is too short to judge) holds when none of these is
seen over the judged span, which starts ``settle`` seconds into the run:

1. GROWING ENERGY. The loop's mechanical energy (the replica arm's and the handle's kinetic energy; from a bag, the
   controller's stored plus kinetic energy) peaks higher in every window of W = max(``min_window``, 2 round trips)
   than in the one before (windows mostly in contact left out), over the judged span, ending above
   ``energy_growth_ratio`` times the first window's peak and above ``energy_floor``. A delayed loop with too little
   damping gains energy every cycle (Anderson and Spong 1989); the kinetic energy of an oscillation of period P
   peaks every P/2, so a window of 2 round trips holds a full energy period of the slowest delay-induced
   oscillation. Rising in EVERY window, not just last against first: an operator's aperiodic moves make the peaks go
   up and down, a growing oscillation makes them rise. With a quiet tail the windows cover the tail after its flush
   (2'), not the task: energy that grows from one of the operator's moves to the next is driven, not the loop's.
2'. FREE OSCILLATION IN THE QUIET TAIL (runs with a tail). The tail's first ``tail_flush`` seconds (1 s) and one round
   trip are left out: the operator's last target reaches the replica one delay after it stops and the replica's
   answer reaches the hand another delay later, and the planner comes to rest within 0.8 s (fic_core.
   stopped_trajectory). What follows must last max(4 round trips, 8 s) (``tail_needed``; shorter: not assessed): a
   delay-induced oscillation has a period of at most about 4 round trips, so it holds one period of the slowest and
   two of its kinetic-energy peaks, and 8 s holds several periods of the arm's and the hand's own modes. It is cut into
   windows of max(2 s, 2 round trips) (half the slowest period: each holds a kinetic-energy peak), half a window apart
   (at least 3). Per window, each motion the scan looks at (x_M minus the hand's target, x_d and x_R minus the command,
   x_d - x_R) has an amplitude (sqrt 2 times its RMS about the window's mean, largest axis) and the arm's and handle's
   kinetic energy a peak. A motion is a FREE OSCILLATION when it is above ``tail_motion_floor`` (1 mm, 2 % of x_b: the
   claim runs' driven swings fall from 10-15 mm to 0.1-0.9 mm once the input stops) in each of the last 3 windows
   and does not decay: its last window keeps at least ``tail_motion_decay`` (0.7) of its first window's amplitude, or
   at least 0.7^(share of the span) of its middle window's (the same rate over the later half: an exponential decay
   meets both or neither, a stop's transient dying out on top of a steady oscillation meets only the first). The
   energy likewise, with ``tail_energy_decay`` (0.5 = 0.7^2, the same decay in energy) above ``energy_floor``. Why 0.7:
   a free response that loses less than half its energy from the first window to the last (at long delays half the
   slowest delay-induced period apart: a damping ratio under 0.11 there, e^(-pi zeta) = 0.7; at short delays 6 s
   apart: an amplitude time constant over 17 s) is at the edge of stability, and to the operator it is an
   oscillation. A decaying
   response is a stable loop whatever its size; a motion below the floor is rest.
2. SUSTAINED OSCILLATION (runs WITHOUT a tail: a bag, a run kept before tails; with a tail the same scan runs over the
   task only and is REPORTED, not judged: ``swing_m``, x_R's largest swing about its command (the scan's amplitude of
   x_R - command with nothing excused, at the period where most of its windows oscillate), and the forced-answer fit's
   figures below) at any period from 0.2 s to the longest the span holds 1.5 times (which must reach
   max(4 round trips, ``min_longest_period``), else the run is not assessed): fic_teleop_tools.verdict.oscillation_scan
   on each motion minus its known command (x_M minus the hand's target; x_d and x_R minus the commanded motion; the
   tracking error x_d - x_R), outside contact, LESS THE LOOP'S FORCED ANSWER to its exogenous input
   (fic_teleop_tools.verdict.forced_answer: causal kernels from the planner's motion and the operator's planned
   target, fitted over the run and predicted out of sample, beside a free sinusoid at the period where what a first
   fit leaves oscillates). A stable but under-damped loop swings about its command at its resonance whenever the
   command moves there; that swing is its answer to the input, not an oscillation of its own, and the fit takes it
   out. The fit's peak gain from the operator's target to x_R (``resonance_gain`` at ``resonance_period_s``) is
   reported, so that an under-damped loop stays visible. Without exogenous input (a bag) the motion is scanned as it
   is, with the command's excuse of oscillation_scan where a command is known: conservative, and the notes say so.
   A delay-induced oscillation has a period of at most about 4 round trips (its phase lag of pi/2 to pi accrues over
   one round trip).
3. STEADY ENERGY GENERATION AT THE CHANNEL'S PORTS, judged as a rate: the channel's generated energy (what left it at
   both ports minus what entered, the time-domain passivity observers' sum) rises over the judged span outside
   contact by more than ``port_rate_limit`` watts on average. A passive channel generates nothing; a delayed one
   generates while the operator moves, and a stable loop damps that away without a steady rise. A collision makes a
   burst (the force reaches the handle one delay late, while the hand still moves): contact is left out here too.
4. RUNAWAY: kinetic energy above ``kinetic_energy_bound``, a joint faster than the Panda datasheet's limit, or a
   tracking error |x_d - x_R| beyond ``runaway_error`` x_b (4 x_b) outside contact.
5. PARKED far from the target: |x_d - x_R|, or |x_R - command| when the command is known, above ``parked_error`` x_b
   (2 x_b) for ``parked_hold`` seconds on end outside contact.

SAFE holds when the run shows no limit violation (a tick whose command or state broke a Panda limit), no velocity
reflex trip, no safe hold (the replica's input safe hold, the robot's stale-command hold) and no repeated collision:
the obstacle the task steers around (the scene's contact flag) touched in ``collisions_allowed`` + 1 or more separate
episodes (``collision_gap`` apart: a bounce is one). A count that was not recorded is reported as such, not judged.

CONTACT is told apart from instability with the scene's contact data: a sample is in contact when the F/T force is
at least ``contact_force`` or was within the last ``contact_hold`` seconds (the free-motion definition of
docs/EXPERIMENTS.md), or the contact flag is set; the oscillation, port-generation, runaway-error and parked tests
leave out the contact samples and ``contact_margin`` + one round trip around them (the hand feels the contact one
delay later and the replica sees the hand's answer another delay later). A push into an obstacle is contact, not
instability.

``judge`` is a pure function of the stored series (VerdictInput), so a sweep's runs are re-judged without simulating.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray
from threadpoolctl import threadpool_limits

from fic_core.arm_profile import arm_profile
from fic_core.teleoperation import TeleoperationMode
from fic_teleop_tools.verdict.forced_answer import Channel, ForcedAnswer, ForcedSettings, fit, free_oscillation_period
from fic_teleop_tools.verdict.oscillation_scan import Oscillation, ScanSettings, scan

if TYPE_CHECKING:
    from fic_teleop_tools.report.bag_data import BagData

X_B = 0.05   # [m] the paper's error bound x_b (Sec. III)


class VerdictInputError(ValueError):
    """Series that cannot be judged (shape, NaN in the time, time not increasing, too few samples)."""


@dataclass(frozen=True)
class VerdictCriterion:
    """The thresholds of the two verdicts (module docstring); SI units."""

    settle: float = 2.0                  # [s] start-up left out of the stability tests
    tail_min: float = 8.0                # [s] a quiet tail's judged free response: at least this long ...
    tail_round_trips: float = 4.0        # ... and this many round trips, after
    tail_flush: float = 1.0              # [s] + one round trip, while the last input leaves the loop
    tail_motion_floor: float = 0.001     # [m] free motion under this amplitude is rest (2 % of x_b)
    tail_motion_decay: float = 0.7       # last tail window's amplitude over the first's under this: decaying
    tail_energy_decay: float = 0.5       # last tail window's kinetic-energy peak over the first's under this
    min_window: float = 2.0              # [s] energy windows: max(min_window, 4 round trips)
    min_longest_period: float = 4.0      # [s] the oscillation scan must reach at least this period (zero delay)
    round_trips_judged: float = 4.0      # ... and at least this many round trips
    energy_growth_ratio: float = 2.0     # last window's energy peak over the first judged window's
    energy_floor: float = 2.5e-3         # [J] nothing below it grows: 1/2 200 N/m (5 mm)^2
    port_rate_limit: float = 0.05        # [W] mean generation at the channel's ports over the judged span
    kinetic_energy_bound: float = 10.0   # [J] the Panda (about 8 kg effective) at its 1.7 m/s TCP speed limit
    runaway_error: float = 4.0           # [x_b] |x_d - x_R| outside contact (x_b: the run's, VerdictInput.x_b)
    parked_error: float = 2.0            # [x_b] |x_d - x_R| or |x_R - command| outside contact ...
    parked_hold: float = 3.0             # [s] ... on end
    contact_force: float = 1.0           # [N] F/T force of contact
    contact_hold: float = 0.2            # [s] free motion only this long after the force fell below it
    contact_margin: float = 0.5          # [s] + one round trip left out around contact (both sides)
    collisions_allowed: int = 1          # separate episodes of contact with the obstacle the task avoids ...
    collision_gap: float = 1.0           # [s] ... apart by at least this much (a bounce is one collision)
    resample_period: float = 0.01        # [s] the uniform grid the series are judged on
    joint_speed_limit: tuple[float, ...] = arm_profile("panda").joint_velocity   # [rad/s] the datasheet's
    scan: ScanSettings = field(default_factory=ScanSettings)
    forced: ForcedSettings = field(default_factory=ForcedSettings)

    def longest_period_needed(self, one_way_delay: float) -> float:
        return max(self.round_trips_judged * 2.0 * one_way_delay, self.min_longest_period)

    def run_needed(self, one_way_delay: float) -> float:
        """[s] the least run (without a quiet tail) whose oscillation scan reaches ``longest_period_needed``."""
        return self.settle + self.scan.min_cycles * self.longest_period_needed(one_way_delay)

    def tail_flush_s(self, one_way_delay: float) -> float:
        """[s] the start of a quiet tail that is not judged: the last input leaves the loop (module docstring)."""
        return self.tail_flush + 2.0 * one_way_delay

    def tail_needed(self, one_way_delay: float) -> float:
        """[s] the least quiet tail the free-response test judges: its flush, then max(4 round trips, 8 s)."""
        return self.tail_flush_s(one_way_delay) + max(self.tail_round_trips * 2.0 * one_way_delay, self.tail_min)

    def tail_window(self, one_way_delay: float) -> float:
        """[s] the free-response test's window: half the slowest delay-induced period (2 round trips), at least
        ``min_window``, so that every window holds a kinetic-energy peak of it."""
        return max(self.min_window, 0.5 * self.round_trips_judged * 2.0 * one_way_delay)


@dataclass
class VerdictInput:
    """One run's series on one time base (n samples); every field but time, one_way_delay and one of x_R or
    tracking_error may be None (not recorded: the test that needs it is skipped and says so)."""

    time: NDArray                                   # [s] (n,)
    one_way_delay: float                            # [s] the channel's, each way
    x_R: NDArray | None = None                      # the replica's TCP position (n, 3) [m]
    x_d: NDArray | None = None                      # the replica's set point (n, 3) [m]
    x_M: NDArray | None = None                      # the handle position (n, 3) [m]
    command: NDArray | None = None                  # commanded TCP motion one delay later (from_run_result)
    planner: NDArray | None = None                  # the planner's part of it (n, 3) [m]: x_M answers it too
    operator_target: NDArray | None = None          # the hand's target for x_M (n, 3) [m]
    tracking_error: NDArray | None = None           # x_d - x_R (n, 3) [m]; from x_d and x_R when not given
    arm_kinetic_energy: NDArray | None = None       # 1/2 qd^T M(q) qd (n,) [J]
    handle_kinetic_energy: NDArray | None = None    # 1/2 m_h |v_M|^2 (n,) [J]
    controller_energy: NDArray | None = None        # a bag's stored + kinetic energy (n,) [J], when no kinetic energy
    contact: NDArray | None = None                  # touching the obstacle the task steers around (n,) bool
    force: NDArray | None = None                    # F/T force at the TCP (n, 3) [N]
    channel_generated: NDArray | None = None        # cumulative energy the channel generated (n,) [J]
    # Per direction: each side's passivity observer W = E_in at the other side one delay ago - E_out here (n, 2)
    # [J], the handle's side first; a fall of W is energy that direction created (reported, not judged).
    channel_observers: NDArray | None = None
    joint_speed: NDArray | None = None              # peak |qd| per joint since the previous sample (n, 7) [rad/s]
    joint_speed_peak: float | None = None           # the fastest joint's peak over the run [rad/s], joint not known
    limit_violations: int | None = None             # ticks that broke a Panda limit over the run
    reflex_trips: int | None = None                 # velocity reflex trips
    safe_holds: int | None = None                   # the replica's input safe hold latched
    stale_holds: int | None = None                  # the robot held on stale torque commands
    x_b: float = X_B                                # [m]
    source: str = ""                                # what the series came from (for the reasons)
    # [s] the start of the run's quiet tail (no planner motion, the operator's target still; in_process.RunConfig):
    # STABLE is judged on the free response there. None: no tail (a bag, a run kept before tails).
    quiet_from: float | None = None

    @classmethod
    def from_run_result(cls, result, one_way_delay: float, x_b: float = X_B) -> "VerdictInput":
        """From an in-process run (fic_teleop_experiments.in_process.RunResult, or one loaded by
        claims.load_series): the commanded motion as the replica receives it, one delay later. In offset mode
        throughout (or when the run did not record the master's mode) it is the planner's plus the hand's target
        (x_d' = s_M x_M with s_M = 1, Eq. 3). Once the master was in velocity mode the hand's target is a velocity
        command, not a place: x_d' is the integral of k_v x_M (Eq. 3), and after it an offset-mode stretch continues
        from that integral, so the command is the planner's plus the x_d' the master sent."""
        time = np.asarray(result.time, dtype=float)
        command = None
        mode = getattr(result, "command_mode", None)
        sent = getattr(result, "sent_offset", None)
        velocity = mode is not None and len(mode) == len(time) and \
            bool(np.any(np.asarray(mode) != TeleoperationMode.OFFSET))
        if velocity and result.planner is not None and sent is not None:
            command = result.planner + np.column_stack([np.interp(time - one_way_delay, time, sent[:, axis])
                                                        for axis in range(3)])
        elif result.planner is not None and result.operator_target is not None:
            later = np.column_stack([np.interp(time - one_way_delay, time, result.operator_target[:, axis])
                                     for axis in range(3)])
            command = result.planner + later
        ports = result.port_energy
        # The runner keeps the fastest joint, the robot's stale-command watchdog and the replica's holds over every
        # physics step (absent from older series: not recorded). Its velocity reflex trip (velocity_reflex_time) is
        # not read: a series saved before the runner had the reflex cannot tell no trip from no reflex.
        def count(name: str) -> int | None:
            return int(getattr(result, name)) if hasattr(result, name) else None

        return cls(time=time, one_way_delay=float(one_way_delay), x_R=result.tcp, x_d=result.desired,
                   x_M=result.master, command=command, planner=result.planner,
                   operator_target=result.operator_target,
                   arm_kinetic_energy=result.arm_kinetic_energy, handle_kinetic_energy=result.handle_kinetic_energy,
                   contact=result.obstacle_contact, force=result.force,
                   channel_generated=None if ports is None or len(ports) == 0 else ports[:, 2],
                   channel_observers=None if ports is None or len(ports) == 0 else ports[:, :2],
                   joint_speed_peak=float(result.joint_speed_max) if getattr(result, "joint_speed_max", 0.0) else None,
                   limit_violations=int(result.limit_violations), safe_holds=count("replica_holds"),
                   stale_holds=count("robot_watchdog_engagements"), x_b=x_b, source="in-process run",
                   quiet_from=getattr(result, "quiet_from", None))

    @classmethod
    def from_bag(cls, path: str | Path, one_way_delay: float, x_b: float = X_B) -> "VerdictInput":
        """From a recorded session (the report's reader, fic_teleop_tools.report.bag_data; from_bag_data)."""
        from fic_teleop_tools.report.bag_data import load_bag

        return cls.from_bag_data(load_bag(path, joint_velocities=True), one_way_delay, x_b)

    @classmethod
    def from_bag_data(cls, data: "BagData", one_way_delay: float, x_b: float = X_B,
                      quiet_from: float | None = None) -> "VerdictInput":
        """From a session the report has read (``load_bag(..., joint_velocities=True)``: the report and its verdict
        read the bag once): the tracking error and the controller's energy of /replica/fic_state, the F/T force,
        the joint speeds, the limit counter and the nodes' last diagnostics (the robot's reflex and holds, the
        replica's safe hold). A bag holds no command and no obstacle flag: its motion test is on x_d - x_R, its
        contact is the force's. ``quiet_from``: the stamp the run's quiet tail starts at (the launcher's
        --quiet-tail, run.json), None without one."""
        def ordered(topic: str, columns: tuple[str, ...]) -> tuple[NDArray, NDArray]:
            """A topic's stamps and value columns in stamp order (empty when the bag has none)."""
            series = data.series.get(topic)
            if series is None or len(series) == 0:
                return np.zeros(0), np.zeros((0, len(columns)))
            order = np.argsort(series.stamp, kind="stable")
            return series.stamp[order], np.column_stack([series.values[name] for name in columns])[order]

        time, fic = ordered("/replica/fic_state", ("ex", "ey", "ez", "total_energy"))
        if time.size < 8:
            raise VerdictInputError(f"{data.path}: fewer than 8 /replica/fic_state messages ({time.size})")

        def on_time(stamps: NDArray, values: NDArray) -> NDArray | None:
            if stamps.size < 2:
                return None
            return np.column_stack([np.interp(time, stamps, values[:, column]) for column in range(values.shape[1])])

        force = on_time(*ordered("/ft_sensor/wrench", ("fx", "fy", "fz")))
        # The peak speed of each joint since the previous fic_state stamp (a 1 kHz spike is not interpolated away).
        joints = data.series.get("/joint_states")
        velocity = data.joint_velocity
        joint_speed = None
        if joints is not None and len(joints) >= 2 and velocity.ndim == 2 and velocity.shape == (len(joints),
                                                                                                   velocity.shape[1]) \
                and velocity.shape[1]:
            order = np.argsort(joints.stamp, kind="stable")
            joint_speed = _uniform(joints.stamp[order], np.abs(velocity[order]), time, peak=True)
        robot = data.diagnostics.get("robot_sim", {})
        replica = data.diagnostics.get("replica", {})
        reflex = None if "reflex" not in robot else int(bool(robot["reflex"]))
        stale = int(robot["watchdog_engagements"]) if robot.get("watchdog_engagements", "").isdigit() else None
        hold = replica.get("input_safe_hold")
        _, ticks = ordered("/replica/limit_status", ("violation_ticks",))
        violations = int(ticks.max()) if ticks.size else None
        return cls(time=time, one_way_delay=float(one_way_delay), tracking_error=fic[:, :3],
                   controller_energy=fic[:, 3], force=force, joint_speed=joint_speed,
                   limit_violations=violations, reflex_trips=reflex,
                   safe_holds=None if hold is None else int(hold != "no"), stale_holds=stale, x_b=x_b,
                   quiet_from=quiet_from,
                   source=f"bag {data.path.parent.name if data.path.suffix == '.mcap' else data.path.name}")

    @classmethod
    def from_series(cls, run, one_way_delay: float, x_b: float = X_B, source: str = "bag",
                    quiet_from: float | None = None) -> "VerdictInput":
        """From a bag's series (fic_teleop_tools.verdict.bag_series.RunSeries): the tracking error and the
        controller's energy of /replica/fic_state, the F/T force, the joint speeds (when read), the limit counter and
        the nodes' last diagnostics (the robot's reflex and holds, the replica's safe hold). A bag holds no command
        and no obstacle flag: its motion test is on x_d - x_R, its contact is the force's. ``quiet_from``: the
        stamp the run's quiet tail starts at (run_record.quiet_from), None without one."""
        time = run.fic_time
        if time.size < 8:
            raise VerdictInputError(f"{source}: fewer than 8 /replica/fic_state messages ({time.size})")

        def on_time(stamps: NDArray, values: NDArray) -> NDArray | None:
            if stamps.size < 2:
                return None
            return np.column_stack([np.interp(time, stamps, values[:, column]) for column in range(values.shape[1])])

        force = on_time(run.wrench_time, run.force)
        # The peak speed of each joint since the previous fic_state stamp (a 1 kHz spike is not interpolated away).
        joint_speed = _uniform(run.joint_time, np.abs(run.joint_velocity), time, peak=True) \
            if run.joint_time.size >= 2 and run.joint_velocity.ndim == 2 and run.joint_velocity.shape[1] else None
        robot = run.diagnostics.get("robot_sim", {})
        replica = run.diagnostics.get("replica", {})
        reflex = None if "reflex" not in robot else int(bool(robot["reflex"]))
        stale = int(robot["watchdog_engagements"]) if robot.get("watchdog_engagements", "").isdigit() else None
        hold = replica.get("input_safe_hold")
        violations = int(run.violation_ticks.max()) if run.violation_ticks.size else None
        return cls(time=time, one_way_delay=float(one_way_delay), tracking_error=run.error,
                   controller_energy=run.total_energy, force=force, joint_speed=joint_speed,
                   limit_violations=violations, reflex_trips=reflex,
                   safe_holds=None if hold is None else int(hold != "no"), stale_holds=stale, x_b=x_b,
                   source=source, quiet_from=quiet_from)

    def window(self, start: float | None = None, end: float | None = None) -> "VerdictInput":
        """The samples within [start, end] (None: the run's own end); the whole-run counts stay as they are."""
        time = np.asarray(self.time, dtype=float)
        keep = np.ones(time.size, dtype=bool)
        if start is not None:
            keep &= time >= start
        if end is not None:
            keep &= time <= end
        per_sample = {name: value[keep] for name, value in vars(self).items()
                      if isinstance(value, np.ndarray) and value.ndim >= 1 and value.shape[0] == time.size}
        quiet_from = self.quiet_from if self.quiet_from is not None and keep.any() \
            and time[keep][0] < self.quiet_from < time[keep][-1] else None
        return replace(self, **per_sample, quiet_from=quiet_from)


@dataclass
class RunVerdict:
    stable: bool | None                  # None: too short to judge the periods it must
    safe: bool
    stable_reasons: list[str]            # why not stable (or not assessed); empty when stable
    safe_reasons: list[str]              # why not safe; empty when safe
    notes: list[str]                     # tests skipped for want of a series
    figures: dict

    @property
    def reasons(self) -> list[str]:
        return self.stable_reasons + self.safe_reasons

    def as_dict(self) -> dict:
        return asdict(self)

    def summary(self) -> str:
        stable = {True: "STABLE", False: "NOT STABLE", None: "STABILITY NOT ASSESSED"}[self.stable]
        lines = [f"{stable}; {'SAFE' if self.safe else 'NOT SAFE'}"]
        lines += [f"  stable: {reason}" for reason in self.stable_reasons]
        lines += [f"  safe: {reason}" for reason in self.safe_reasons]
        lines += [f"  note: {note}" for note in self.notes]
        return "\n".join(lines)


def _series(name: str, values: ArrayLike | None, n: int, columns: int | None) -> NDArray | None:
    if values is None:
        return None
    array = np.asarray(values, dtype=float)
    if array.ndim == 1 and columns is not None:
        array = array[:, None]
    if array.shape[0] != n or (columns is not None and (array.ndim != 2 or array.shape[1] != columns)):
        raise VerdictInputError(f"{name} must have {n} rows{'' if columns is None else f' of {columns}'}, "
                                f"got shape {array.shape}")
    return array


def _uniform(time: NDArray, values: NDArray | None, grid: NDArray, peak: bool = False) -> NDArray | None:
    """``values`` on ``grid``: linear interpolation, or with ``peak`` the largest sample since the previous grid point
    (a peak is not interpolated away)."""
    if values is None:
        return None
    flat = values.reshape(values.shape[0], -1)
    if not peak:
        out = np.column_stack([np.interp(grid, time, flat[:, column]) for column in range(flat.shape[1])])
    else:
        edges = np.searchsorted(time, grid, side="right")
        out = np.maximum.reduceat(flat, np.minimum(np.r_[0, edges[:-1]], len(time) - 1), axis=0)
    return out.reshape((grid.size,) + values.shape[1:])


def _episodes(flags: NDArray) -> list[tuple[int, int]]:
    """(first, last + 1) sample of each run of True."""
    padded = np.r_[False, flags, False].astype(int)
    changes = np.diff(padded)
    return list(zip(np.nonzero(changes == 1)[0], np.nonzero(changes == -1)[0]))


def _dilated(flags: NDArray, samples: int) -> NDArray:
    if samples <= 0 or not flags.any():
        return flags.copy()
    kernel = np.ones(2 * samples + 1)
    # The full convolution's centre, flags.size long (mode="same" returns the longer of the two, so a margin wider
    # than a short run gave an array longer than the run).
    return np.convolve(flags.astype(float), kernel, mode="full")[samples:samples + flags.size] > 0.0


def _longest_true(flags: NDArray, step: float) -> float:
    episodes = _episodes(flags)
    return max(((last - first) * step for first, last in episodes), default=0.0)


def _energy_windows(time: NDArray, energy: NDArray, free: NDArray, start: float, window: float) -> list[float]:
    """Peaks of ``energy`` outside contact in windows of ``window`` laid end to end back from the run's end (as many
    as fit after ``start``, at least two, overlapping when the span holds fewer); a window mostly in contact is left
    out (a push stores energy in the controller's spring: that is the obstacle's doing)."""
    end = float(time[-1])
    count = max(2, int((end - start) // window))
    lows = np.linspace(start, end - window, count) if end - start < count * window else \
        end - window * np.arange(count, 0, -1)
    peaks = []
    for low in lows:
        inside = (time >= low) & (time <= low + window)
        if np.mean(free[inside]) >= 0.5:
            peaks.append(float(energy[inside & free].max()))
    return peaks


def _free_response(time: NDArray, start: float, window: float, residuals: dict[str, NDArray],
                   energy: NDArray | None, criterion: VerdictCriterion) -> tuple[list[str], dict]:
    """The quiet tail's test (module docstring, 2'): (reasons it is not stable, figures). Windows of ``window`` from
    ``start`` (the tail's start after its flush) to the end, half a window apart; per window, each motion's amplitude
    (sqrt 2 times its RMS about the window's mean, on its largest axis) and the kinetic energy's peak. A series is a
    free oscillation when it is above its floor in each of the last ``scan.min_windows`` windows and does not decay:
    from the first window to the last it keeps at least its decay ratio, or from the middle window to the last at
    least the decay ratio to the power of the share of the span between them (the same rate over the later half: an
    exponential decay meets both or neither; a stop's transient dying out on top of a steady oscillation meets the
    first only)."""
    end = float(time[-1])
    # Half a window apart, the first at ``start``, the last ending at the end (the span is a whole number of half
    # windows up to the last sample's rounding).
    count = max(1, int(round((end - start - window) / (0.5 * window))) + 1)
    lows = np.linspace(start, max(end - window, start), count)
    inside = [(time >= low - 1e-9) & (time <= low + window + 1e-9) for low in lows]
    middle = (count - 1) // 2
    share = (lows[-1] - lows[middle]) / (lows[-1] - lows[0]) if count > 1 else 1.0

    def kept(values: list[float]) -> tuple[float, float]:
        """(last over first, last over middle) of per-window values."""
        return tuple(values[-1] / values[k] if values[k] > 0.0 else float("inf") for k in (0, middle))

    def persists(values: list[float], floor: float, decay: float) -> bool:
        if count < criterion.scan.min_windows or min(values[-criterion.scan.min_windows:]) <= floor:
            return False
        whole, later = kept(values)
        return whole >= decay or later >= decay ** share

    reasons: list[str] = []
    amplitudes: dict[str, list[float]] = {}
    for name, residual in residuals.items():
        values = []
        for rows in inside:
            part = residual[rows]
            values.append(float(np.max(np.sqrt(2.0 * np.mean((part - part.mean(axis=0)) ** 2, axis=0)))))
        amplitudes[name] = values
        if persists(values, criterion.tail_motion_floor, criterion.tail_motion_decay):
            whole, later = kept(values)
            reasons.append(f"free oscillation in the quiet tail: {name} swings {values[-1] * 1e3:.1f} mm in its last "
                           f"window, {whole:.2f} of its first and {later:.2f} of its middle one ({count} windows of "
                           f"{window:g} s; decaying is under {criterion.tail_motion_decay:g} and "
                           f"{criterion.tail_motion_decay ** share:.2f}, rest under "
                           f"{criterion.tail_motion_floor * 1e3:g} mm)")
    ratios = [max(kept(v)[0], kept(v)[1] ** (1.0 / share)) for v in amplitudes.values()]
    figures: dict = dict(tail_window_s=window, tail_windows=count, tail_amplitude_m=amplitudes,
                         tail_motion_max_m=max((v[-1] for v in amplitudes.values()), default=None),
                         tail_motion_ratio=max((r for r in ratios if np.isfinite(r)), default=None))
    if energy is not None:
        peaks = [float(energy[rows].max()) for rows in inside]
        whole, later = kept(peaks)
        figures.update(tail_energy_peaks_j=peaks, tail_energy_ratio=whole if np.isfinite(whole) else None)
        if persists(peaks, criterion.energy_floor, criterion.tail_energy_decay):
            reasons.append(f"energy does not decay in the quiet tail: kinetic energy peaks at {peaks[-1] * 1e3:.3g} mJ "
                           f"in its last window, {whole:.2f} of its first and {later:.2f} of its middle one "
                           f"(decaying is under {criterion.tail_energy_decay:g} and "
                           f"{criterion.tail_energy_decay ** share:.2f}, rest under "
                           f"{criterion.energy_floor * 1e3:g} mJ)")
    return reasons, figures


def _exogenous_channels(name: str, on_grid: dict, delay: float) -> list[Channel]:
    """The exogenous inputs a motion answers (fic_teleop_tools.verdict.forced_answer), at the shifts at which they
    enter the delayed loop. The replica's side (x_d, x_R, their difference) sees the planner at once and the
    operator's target one delay later; the handle (x_M) its target at once and the planner one delay later (the force
    of the replica's lag behind it); through a closed force loop each comes back one round trip later. ``unit``: the
    motion's reference holds that input with gain 1 (the command is the planner plus the target one delay later).
    Never x_M, x_d or what the replica received: they carry the loop's own oscillation."""
    planner, target, command = on_grid["planner"], on_grid["target"], on_grid["command"]
    if name == "x_M - operator target":
        if target is None:
            return []
        wanted = [("operator target", target, 0.0, True)]
        if planner is not None:
            wanted += [("planner", planner, delay, False)]
        wanted += [("operator target", target, 2.0 * delay, False)]
    elif planner is not None and target is not None:
        unit = name != "x_d - x_R"
        wanted = [("planner", planner, 0.0, unit), ("operator target", target, delay, unit),
                  ("planner", planner, 2.0 * delay, False), ("operator target", target, 3.0 * delay, False)]
    elif command is not None and target is None and planner is None:
        # The command alone (a run that recorded it but not its parts): exogenous as a whole.
        wanted = [("command", command, 0.0, name != "x_d - x_R"), ("command", command, 2.0 * delay, False)]
    else:
        return []
    channels: list[Channel] = []
    for channel_name, series, shift, unit in wanted:
        if any(c.name == channel_name and abs(c.shift - shift) < 1e-9 for c in channels):
            continue   # no delay: the echoes coincide with the inputs
        channels.append(Channel(channel_name, series, shift, unit))
    return channels


def judge(data: VerdictInput, criterion: VerdictCriterion | None = None) -> RunVerdict:
    """The two verdicts of one run (module docstring)."""
    # One BLAS thread: the fits are small least-squares problems, and BLAS's threads spin while they wait, so with
    # numpy's default threads a judgement on a busy machine cost about 5 CPU-s instead of 0.2 (docs/RESULTS.md).
    with threadpool_limits(limits=1):
        return _judge(data, criterion or VerdictCriterion())


def _judge(data: VerdictInput, criterion: VerdictCriterion) -> RunVerdict:
    raw_time = np.asarray(data.time, dtype=float)
    if raw_time.ndim != 1 or raw_time.size < 8 or not np.all(np.isfinite(raw_time)) or np.any(np.diff(raw_time) <= 0):
        raise VerdictInputError("time must be a finite, strictly increasing 1-D array of at least 8 samples")
    if not np.isfinite(data.one_way_delay) or data.one_way_delay < 0.0:
        raise VerdictInputError(f"one_way_delay must be a finite number >= 0, got {data.one_way_delay}")
    if not np.isfinite(data.x_b) or data.x_b <= 0.0:
        raise VerdictInputError(f"x_b must be a finite number > 0, got {data.x_b}")
    if data.quiet_from is not None and not (np.isfinite(data.quiet_from)
                                            and raw_time[0] < data.quiet_from < raw_time[-1]):
        raise VerdictInputError(f"quiet_from must be a time within the run ({raw_time[0]:g} to {raw_time[-1]:g} s), "
                                f"got {data.quiet_from}")
    n = raw_time.size
    x_R, x_d = _series("x_R", data.x_R, n, 3), _series("x_d", data.x_d, n, 3)
    x_M, command = _series("x_M", data.x_M, n, 3), _series("command", data.command, n, 3)
    planner = _series("planner", data.planner, n, 3)
    target = _series("operator_target", data.operator_target, n, 3)
    error = _series("tracking_error", data.tracking_error, n, 3)
    if error is None and x_d is not None and x_R is not None:
        error = x_d - x_R
    if error is None and x_R is None:
        raise VerdictInputError("a run needs x_R or the tracking error x_d - x_R")
    kinetic = [_series(name, getattr(data, name), n, None) for name in ("arm_kinetic_energy", "handle_kinetic_energy")]
    kinetic = [k for k in kinetic if k is not None]
    energy = sum(kinetic) if kinetic else _series("controller_energy", data.controller_energy, n, None)
    contact_flag = _series("contact", data.contact, n, None)
    force = _series("force", data.force, n, 3)
    generated = _series("channel_generated", data.channel_generated, n, None)
    observers = _series("channel_observers", data.channel_observers, n, 2)
    joint_speed = _series("joint_speed", data.joint_speed, n, None)
    if joint_speed is not None and (joint_speed.ndim != 2 or not 1 <= joint_speed.shape[1] <= 7):
        raise VerdictInputError(f"joint_speed must have 1 to 7 columns, got shape {joint_speed.shape}")

    step = max(criterion.resample_period, float(np.median(np.diff(raw_time))))
    time = np.arange(raw_time[0], raw_time[-1] + 0.5 * step, step)
    time = time[time <= raw_time[-1] + 1e-9]
    on_grid = {name: _uniform(raw_time, values, time) for name, values in dict(
        x_R=x_R, x_d=x_d, x_M=x_M, command=command, planner=planner, target=target, error=error, energy=energy,
        force=force, generated=generated, observers=observers).items()}
    speed = _uniform(raw_time, joint_speed, time, peak=True)
    flag = _uniform(raw_time, None if contact_flag is None else contact_flag.astype(float), time, peak=True)
    notes: list[str] = []
    stable_reasons: list[str] = []
    safe_reasons: list[str] = []
    figures: dict = {"source": data.source, "one_way_delay_s": data.one_way_delay,
                     "duration_s": float(time[-1] - time[0])}
    finite = all(np.all(np.isfinite(v)) for v in on_grid.values() if v is not None)
    if not finite:
        stable_reasons.append("NaN or Inf in the series: the run blew up")

    # Contact (module docstring): the force's free-motion definition, the scene's flag, a margin around both.
    round_trip = 2.0 * data.one_way_delay
    contact = np.zeros(time.size, dtype=bool)
    touch = np.zeros(time.size, dtype=bool)   # the contact itself, without the free-motion hold after it
    if on_grid["force"] is not None:
        pressing = np.linalg.norm(np.nan_to_num(on_grid["force"]), axis=1) >= criterion.contact_force
        touch |= pressing
        hold = int(round(criterion.contact_hold / step))
        contact |= np.convolve(pressing.astype(float), np.ones(hold + 1), mode="full")[:time.size] > 0.0
    else:
        notes.append("no F/T force: contact is known only from the contact flag")
    touching = flag[:, 0] > 0.5 if flag is not None and flag.ndim == 2 else (flag > 0.5 if flag is not None else None)
    if touching is not None:
        contact |= touching
        touch |= touching
    else:
        notes.append("no contact flag: collisions are not judged")
    excluded = _dilated(contact, int(round((criterion.contact_margin + round_trip) / step)))
    free = ~excluded
    judged_from = float(time[0]) + criterion.settle
    judged = time >= judged_from
    figures.update(contact_share=float(contact[judged].mean()), excluded_share=float(excluded[judged].mean()),
                   judged_from_s=criterion.settle)

    # 4. Runaway (whole run for energy and joint speed; outside contact after settling for the error).
    if energy is not None and finite:
        peak_energy = float(np.max(on_grid["energy"]))
        figures["energy_peak_j"] = peak_energy
        if kinetic and peak_energy > criterion.kinetic_energy_bound:
            stable_reasons.append(f"runaway: kinetic energy {peak_energy:.3g} J above "
                                  f"{criterion.kinetic_energy_bound:g} J")
    if speed is not None:
        ratio = speed / np.asarray(criterion.joint_speed_limit)[None, :speed.shape[1]]
        worst = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
        figures["joint_speed_ratio_max"] = float(ratio[worst])
        if ratio[worst] > 1.0:
            stable_reasons.append(f"runaway: joint {worst[1] + 1} at {speed[worst]:.2f} rad/s, over the datasheet's "
                                  f"{criterion.joint_speed_limit[worst[1]]:.3f} rad/s at {time[worst[0]]:.1f} s")
    elif data.joint_speed_peak is not None:
        # One peak for all joints: over the fastest joints' limit it is over every joint's; between the two
        # limits the joint decides, which the series does not say.
        fastest, slowest = max(criterion.joint_speed_limit), min(criterion.joint_speed_limit)
        figures["joint_speed_peak"] = data.joint_speed_peak
        if data.joint_speed_peak > fastest:
            stable_reasons.append(f"runaway: a joint at {data.joint_speed_peak:.2f} rad/s, over every joint's "
                                  f"datasheet limit ({fastest:.3f} rad/s)")
        elif data.joint_speed_peak > slowest:
            notes.append(f"a joint reached {data.joint_speed_peak:.2f} rad/s: over the limit of joints 1-4 "
                         f"({slowest:.3f} rad/s) if it was one of them (the series does not say which)")
    else:
        notes.append("no joint speeds: the datasheet speed test is skipped")
    magnitude = np.linalg.norm(on_grid["error"], axis=1) if on_grid["error"] is not None else None
    runaway_bound, parked_bound = criterion.runaway_error * data.x_b, criterion.parked_error * data.x_b
    if magnitude is not None and finite:
        free_error = magnitude[judged & free]
        figures["free_error_max_m"] = float(free_error.max()) if free_error.size else None
        if free_error.size and free_error.max() > runaway_bound:
            stable_reasons.append(f"runaway: tracking error {free_error.max() * 1e3:.0f} mm outside contact, above "
                                  f"{runaway_bound * 1e3:.0f} mm ({criterion.runaway_error:g} x_b)")
    # 5. Parked far from the target.
    parked_signals = {"|x_d - x_R|": magnitude}
    if on_grid["command"] is not None and on_grid["x_R"] is not None:
        parked_signals["|x_R - command|"] = np.linalg.norm(on_grid["x_R"] - on_grid["command"], axis=1)
    for name, values in parked_signals.items():
        if values is None or not finite:
            continue
        far = (values > parked_bound) & judged & free
        longest = _longest_true(far, step)
        figures[f"parked_s {name}"] = longest
        if longest >= criterion.parked_hold:
            stable_reasons.append(f"parked: {name} above {parked_bound * 1e3:.0f} mm for {longest:.1f} s on end "
                                  f"outside contact (limit {criterion.parked_hold:g} s)")

    needed = criterion.longest_period_needed(data.one_way_delay)
    reach = (float(time[-1]) - judged_from) / criterion.scan.min_cycles
    figures.update(longest_period_needed_s=needed, longest_period_judged_s=reach)
    # The task: the run before its quiet tail (all of it without one). The oscillation scan looks at the task only.
    quiet_from = data.quiet_from
    task = np.ones(time.size, dtype=bool) if quiet_from is None else time < quiet_from
    if quiet_from is None:
        assessed = reach >= needed
        notes.append("no quiet tail: STABLE is judged by the oscillation scan during the task (a driven swing can "
                     "read as an oscillation there)")
    else:
        tail_span, tail_needed = float(time[-1]) - quiet_from, criterion.tail_needed(data.one_way_delay)
        figures.update(quiet_from_s=quiet_from, tail_s=tail_span, tail_needed_s=tail_needed)
        # Two samples short is whole: the kept series' last sample is a step before the run's end.
        assessed = tail_span >= tail_needed - 2.0 * step
    scan_free = free & task
    if finite and assessed:
        # 1. Growing energy.
        if energy is not None:
            # The kinetic energy of an oscillation of period P peaks every P/2: windows of 2 round trips hold a full
            # energy period of the slowest delay-induced oscillation (4 round trips).
            window = max(criterion.min_window, 0.5 * criterion.round_trips_judged * round_trip)
            # With a quiet tail, over the tail after its flush: stability is the free response's, and during the task
            # the operator's moves drive the energy (a push that grows from one move to the next is not the loop's).
            grown_from = judged_from if quiet_from is None else quiet_from + criterion.tail_flush_s(data.one_way_delay)
            peaks = _energy_windows(time, on_grid["energy"].reshape(time.size, -1)[:, 0], free, grown_from, window)
            if len(peaks) < 2:
                peaks = peaks or [0.0]
                notes.append("fewer than two energy windows outside contact: the growth test is skipped")
            growth = peaks[-1] / peaks[0] if peaks[0] > 0.0 else (float("inf") if peaks[-1] > 0.0 else 1.0)
            figures.update(energy_window_s=window, energy_window_peaks_j=peaks,
                           energy_growth=growth if np.isfinite(growth) else None)
            rising = all(later > earlier for earlier, later in zip(peaks, peaks[1:]))
            if len(peaks) >= 2 and peaks[-1] > criterion.energy_floor and growth > criterion.energy_growth_ratio \
                    and rising:
                stable_reasons.append(f"growing energy: the peaks of {len(peaks)} windows of {window:g} s rise in "
                                      f"every window to {peaks[-1] * 1e3:.3g} mJ, {growth:.1f}x the first's (limit "
                                      f"{criterion.energy_growth_ratio:g}x)")
        else:
            notes.append("no energy series: the growth test is skipped")
        # 2. Sustained oscillation, per motion minus its command, less the loop's forced answer to its exogenous
        # input (fic_teleop_tools.verdict.forced_answer).
        signals: dict[str, tuple[NDArray, NDArray | None]] = {}
        if on_grid["x_M"] is not None:
            reference = on_grid["target"] if on_grid["target"] is not None else np.zeros_like(on_grid["x_M"])
            # The hand gives way to the force the replica's lag behind its command sends back: x_M answers the
            # planner as well as its own target.
            known = [k for k in (on_grid["target"], on_grid["planner"]) if k is not None]
            signals["x_M - operator target"] = (on_grid["x_M"] - reference, np.hstack(known) if known else None)
        for name in ("x_d", "x_R"):
            if on_grid[name] is not None and on_grid["command"] is not None:
                signals[f"{name} - command"] = (on_grid[name] - on_grid["command"], on_grid["command"])
        if on_grid["error"] is not None:
            signals["x_d - x_R"] = (on_grid["error"], on_grid["command"])
        # The motions as they are (reported: what the rule without the fit would say), then the fit of each to the
        # exogenous input; where what a first fit leaves oscillates, the fit again with a free sinusoid at that period
        # (forced_answer.fit's free_period), so that the kernels cannot take a free oscillation for an answer to the
        # input; then the scan of what the fit leaves.
        # The swing (a reported figure): x_R about its command as it is, no command excused.
        swing_of = next((name for name in ("x_R - command", "x_d - x_R") if name in signals), None)
        swing = {"swing": (signals[swing_of][0], None)} if swing_of is not None else {}
        before: dict[str, Oscillation] = scan(time, scan_free, judged_from, criterion.scan, {**signals, **swing})
        if swing_of is not None:
            found = before.pop("swing")
            figures.update(swing_m=found.amplitude, swing_period_s=found.period, swing_of=swing_of)
        # The fit's samples: the judged span outside contact and contact_margin around it (the linear answer does not
        # hold while the obstacle holds the arm). The round trip the other tests add is kept in: what contact sets
        # going in the loop is not the input's answer, but it is only a disturbance to a least-squares fit, and the
        # fit needs the samples.
        use = judged & task & ~_dilated(contact, int(round(criterion.contact_margin / step)))
        first: dict[str, tuple[NDArray, list[Channel], ForcedAnswer, dict]] = {}
        designs: dict[tuple, dict] = {}   # the regressors of one set of channels, shared by the fits that use it
        for name, (residual, _) in signals.items():
            channels = _exogenous_channels(name, on_grid, data.one_way_delay) if criterion.forced.enabled else []
            design = designs.setdefault(tuple((c.name, c.shift) for c in channels), {})
            answer = fit(time, residual, channels, use, criterion.forced, design=design) if channels else None
            if answer is not None:
                first[name] = (residual, channels, answer, design)
        hints = scan(time, scan_free, judged_from, criterion.scan,
                     {name: (residual - answer.predicted, None) for name, (residual, _, answer, _) in first.items()}) \
            if first else {}
        scanned: dict[str, tuple[NDArray, NDArray | None]] = {}
        answers: dict[str, ForcedAnswer] = {}
        for name, (residual, known) in signals.items():
            if name not in first:
                scanned[name] = (residual, known)
                continue
            _, channels, answer, design = first[name]
            if hints[name].amplitude > 0.0:
                # The free oscillation's period: where a sinusoid fitted jointly with the kernels leaves least, near
                # the scan's (its grid is 7 % coarse; a periodogram of what the kernels alone leave is pulled off a
                # cycle at the resonance, where the kernels took part of it).
                period = free_oscillation_period(time, residual, channels, use, hints[name].period,
                                                 criterion.forced, design=design)
                answer = fit(time, residual, channels, use, criterion.forced, free_period=period,
                             design=design) or answer
            answers[name] = answer
            # The fitted answer replaces the command's excuse (a window whose command repeats at P with twice the
            # residual's amplitude): what the input explains is gone already, and the excuse would hide a free
            # oscillation at a period where the command repeats.
            scanned[name] = (residual - answer.predicted, None)
        if not answers:
            notes.append("no exogenous input (the planner's motion, the operator's planned target) or too little "
                         "motion outside contact to fit the loop's answer to it: the oscillation test keeps the "
                         "conservative rule (a stable but under-damped loop's answer to the operator's motion reads "
                         "as oscillation)")
        elif len(answers) < len(signals):
            notes.append(f"no forced answer fitted for {', '.join(n for n in signals if n not in answers)}: scanned "
                         "with it (conservative)")
        oscillations: dict[str, Oscillation] = scan(time, scan_free, judged_from, criterion.scan, scanned)
        figures["oscillation"] = {name: found.as_dict() for name, found in oscillations.items()}
        figures["oscillation_with_forced_answer"] = {name: before[name].as_dict() for name in answers}
        figures["forced_answer"] = {name: answer.as_dict() for name, answer in answers.items()}
        resonant = next((name for name in ("x_R - command", "x_d - command", "x_M - operator target")
                         if name in answers and answers[name].gain is not None), None)
        if resonant is not None:
            resonance = answers[resonant].gain
            figures.update(resonance_gain=resonance["peak_gain"], resonance_period_s=resonance["period_s"],
                           resonance_of=resonant.split(" - ")[0])
        for name, found in oscillations.items() if quiet_from is None else ():
            if found.sustained:
                stable_reasons.append(
                    f"sustained oscillation of {name}{' beyond its forced answer' if name in answers else ''}: "
                    f"{found.amplitude * 1e3:.1f} mm at {found.period:.2f} s in "
                    f"{found.window_share:.0%} of {found.windows} windows (sinusoid explains "
                    f"{found.explained_share:.0%}; limits {criterion.scan.amplitude * 1e3:g} mm, "
                    f"{criterion.scan.explained_share:.0%}, {criterion.scan.sustained_share:.0%} of windows)")
            elif name in answers and before[name].sustained:
                forced = before[name]
                share = float(np.mean(answers[name].explained_share))
                notes.append(f"{name}: {forced.amplitude * 1e3:.1f} mm at {forced.period:.2f} s is the loop's forced "
                             f"answer to its exogenous input (the fit explains {share:.0%} of its variance, mean over "
                             f"the axes; what it leaves does not oscillate), not counted")
        # 2'. With a quiet tail: the free response decays (module docstring), the oscillation scan only reported.
        if quiet_from is not None:
            window = criterion.tail_window(data.one_way_delay)
            tail_energy = on_grid["energy"].reshape(time.size, -1)[:, 0] if on_grid["energy"] is not None else None
            # A contact in the tail is an input from the surroundings: the free response follows the last one, when
            # the tail holds enough of it (a claim run's tail goes on after a touch for that, in_process.RunConfig
            # tail_clear). Else the whole tail, contacts and all: a cycle through the surroundings that recurs to the
            # end is the loop's own oscillation.
            touched = np.flatnonzero(touch & (time >= quiet_from))
            free_from = quiet_from
            if touched.size and float(time[-1]) - float(time[touched[-1]]) >= tail_needed - 2.0 * step:
                free_from = float(time[touched[-1]])
                figures["tail_free_from_s"] = free_from
            reasons, found = _free_response(time, free_from + criterion.tail_flush_s(data.one_way_delay), window,
                                            {n: r for n, (r, _) in signals.items()}, tail_energy, criterion)
            stable_reasons += reasons
            figures.update(found)
        # 3. Steady generation at the channel's ports.
        if on_grid["generated"] is not None:
            values = on_grid["generated"].reshape(time.size, -1)[:, 0]
            first = int(np.searchsorted(time, judged_from))
            span = float(time[-1] - time[first])
            # Judged outside contact, like the oscillation: a collision through the delay makes a burst at the ports
            # (the force reaches the handle one delay after the hit, while the hand still moves), which the loop
            # then damps away; steady generation is what goes on in free motion. The whole span's rate is reported.
            step_free = free[1:] & free[:-1] & judged[1:] & judged[:-1]
            free_span = float(np.count_nonzero(step_free) * step)

            def free_rise_rate(series: NDArray) -> NDArray:
                """The series' rise over the judged steps outside contact, per second of them."""
                return np.diff(series, axis=0)[step_free].sum(axis=0) / max(free_span, step)

            rate_all = float((values[-1] - values[first]) / span)
            figures.update(channel_generated_total_j=float(values[-1]), channel_generation_rate_all_w=rate_all,
                           channel_generation_free_s=free_span)
            if on_grid["observers"] is not None:
                fall = -free_rise_rate(on_grid["observers"])
                figures["channel_generation_rate_by_direction_w"] = {
                    "to the handle": float(fall[0]), "to the replica": float(fall[1])}
            if free_span < max(criterion.min_window, 2.0 * round_trip):
                notes.append(f"{free_span:.1f} s outside contact: too little to judge the channel's generation rate")
            else:
                rate = float(free_rise_rate(values))
                figures["channel_generation_rate_w"] = rate
                if rate > criterion.port_rate_limit:
                    stable_reasons.append(
                        f"steady energy generation at the channel's ports: {rate * 1e3:.0f} mW over the "
                        f"{free_span:.1f} s judged outside contact (limit {criterion.port_rate_limit * 1e3:.0f} mW)")
        else:
            notes.append("no channel port energy: the generation-rate test is skipped")
    elif finite and quiet_from is not None:
        stable_reasons.append(f"not assessed: a quiet tail of {float(time[-1]) - quiet_from:.1f} s, the free response "
                              f"needs {criterion.tail_needed(data.one_way_delay):.1f} s ({criterion.tail_flush:g} s "
                              f"and a round trip of flush, then max({criterion.tail_round_trips:g} round trips, "
                              f"{criterion.tail_min:g} s))")
    elif finite:
        stable_reasons.append(f"not assessed: periods up to {needed:.1f} s (max(4 round trips, "
                              f"{criterion.min_longest_period:g} s)) need "
                              f"{criterion.run_needed(data.one_way_delay):.1f} s of run, it has "
                              f"{time[-1] - time[0]:.1f} s")
    stable: bool | None = not stable_reasons
    if finite and not assessed:
        runaway = [reason for reason in stable_reasons if not reason.startswith("not assessed")]
        stable = False if runaway else None

    # SAFE.
    for name, what in (("limit_violations", "limit violation ticks"), ("reflex_trips", "velocity reflex trips"),
                       ("safe_holds", "input safe holds"), ("stale_holds", "stale-command holds of the robot")):
        count = getattr(data, name)
        figures[name] = count
        if count is None:
            notes.append(f"{what}: not recorded")
        elif count > 0:
            safe_reasons.append(f"{count} {what}")
    if touching is not None:
        episodes: list[tuple[int, int]] = []
        for first, last in _episodes(touching):
            if episodes and (first - episodes[-1][1]) * step < criterion.collision_gap:
                episodes[-1] = (episodes[-1][0], last)      # a bounce or chatter within one strike
            else:
                episodes.append((first, last))
        figures["collisions"] = len(episodes)
        if len(episodes) > criterion.collisions_allowed:
            safe_reasons.append(f"{len(episodes)} collisions with the obstacle the task steers around (at "
                                f"{', '.join(f'{time[first]:.1f}' for first, _ in episodes[:6])} s; "
                                f"{criterion.collisions_allowed} allowed)")
    return RunVerdict(stable, not safe_reasons, stable_reasons if stable is not True else [], safe_reasons, notes,
                      figures)

