"""The metrics of a recorded session (defined in docs/EXPERIMENTS.md, "Metrics"), as implemented here.

Time base: header stamps (sim time in lockstep mode); t0 = the first /joint_states stamp (else the earliest
stamp of any decoded topic). Warm-up: samples stamped before t0 + warmup_s (default 2 s: the arm settling, DDS
discovery) are left out of the error, force, energy, latency and delay figures and of the real-time factor;
limit counts and dropped joint states cover the whole recording.

- tracking error e(t) = |x_d - x_R| of the TCP position: /replica/desired_pose and /replica/tcp_pose joined on
  equal stamps (interpolating x_d at the x_R stamps if the stamps differ); without them |FicState.error[0:3]|.
- free motion at time t: the latest /ft_sensor/wrench sample at or before t has |F| < 1 N and no sample in the
  0.2 s before it had |F| >= 1 N (the first 0.2 s of the F/T stream count as contact); contact otherwise.
  Without an F/T topic every sample counts as free motion.
- free_motion_error_max_m / _rms_m: max / RMS of e over free-motion samples; contact_error_max_m: max of e over
  contact samples; peak_interaction_force_n: max |F| of the F/T samples.
- limit_violations / limit_shaped_ticks: the replica's cumulative violation / shaped tick counters (every control
  tick counts, whatever the status rate): those of the last LimitStatus or of the replica's last /diagnostics
  record, whichever counted more ticks (`limit_counters_source` says which); for bags whose LimitStatus has no
  counters (ticks = 0), the number of messages with violations != 0 / shaping != 0.
- not_measured: for each safety figure left null (the error, the limit counts, the real-time factor), why: a starved
  recorder keeps only part of a run, and "n/a" alone read as if the run had none.
- pipeline latency: for each master sample (FicState.master_stamp != 0, first occurrence in stamp order):
  FicState.master_age (its age at the control tick that first used it) - held, where held is
  ChannelDelivery.held of the /channel/deliveries message with topic /replica/teleop_command and header.stamp ==
  master_stamp; p50 and p99 (numpy linear percentiles) in ms. Samples without a delivery are counted as
  `pipeline_latency_unmatched`.
- real_time_factor: (last - first /clock time) / (last - first receive time) after the warm-up (/clock is sim
  time in both sim modes); without /clock, the same with /joint_states stamps.
- dropped_joint_states: over consecutive /joint_states in receive order, sum of round(dt / 1 ms) - 1 for dt > 0;
  only when >= 99 % of the stamps lie on the 1 ms step grid (lockstep: sim time), else null (realtime mode
  stamps with the node clock, where a gap cannot be told from a late step). joint_states_out_of_order: stamps
  older than the one before them; joint_states_repeated: stamps equal to it (lockstep republishing).
- recorder_lost_messages: messages of any topic DDS lost before the recorder took them (the recorder's
  message-lost events, from the bag's metadata.yaml); null when the bag does not say (the recorder's
  count_lost_messages is off by default).
- delay_one_way_ms: median ChannelDelivery.held on /replica/teleop_command and /replica/master_pose, in ms.
- channel_ports: the channel ports' live time-domain passivity observers (fic_core.channel_ports) as the last
  /diagnostics status of each ("master: channel port", "replica: channel port") gave them, up to one
  diagnostics period before the end; channel_forward_generated_j / channel_backward_generated_j: -W of the replica
  / master observer (what that link let out beyond what the other side put in, as known there);
  channel_observed_generated_j: E_out,M + E_out,R - E_in,M - E_in,R, the balance the in-process runner sums;
  channel_port_negative_ticks: ticks either observer booked with W < 0. All null without those statuses.
- exchanged_energy: the FIC ports' exchanged-energy observers (fic_core.exchanged_energy_ports), per side
  ("replica", "master") as their last /diagnostics status gave them: the held effort's work, the margin against the
  attractor's storage and its minimum, the discrete-time shortfall, the damping that covers it, the violation
  ticks; null for a side without its status. exchanged_energy_violation_ticks: both sides' violation ticks.
- duration_s: sim time covered by /clock (else /joint_states) stamps; controller: most frequent
  FicState.controller.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .bag_data import FIC_STATE_TOPIC, FORWARD_TOPICS, LIMIT_STATUS_TOPIC, BagData

# Targets of the default run (docs/EXPERIMENTS.md, "Metrics"): metric -> (comparison, value). The real-time factor's
# is also the launcher's "machine was starved" bound unless a run profile sets its own (timing_bounds in
# fic_teleop_bringup; the launcher then hands it to the report, ReportSettings.real_time_factor_target): this is the
# one place the default lives, as the bringup package imports this one and never the other way round.
TARGETS = {
    "free_motion_error_max_m": ("<", 0.05),
    "free_motion_error_rms_m": ("<", 0.01),
    "limit_violations": ("==", 0),
    "pipeline_latency_p99_ms": ("<", 5.0),
    "real_time_factor": (">=", 0.95),
    "dropped_joint_states": ("==", 0),
    "recorder_lost_messages": ("==", 0),
    "passivity_violation_ticks": ("==", 0),
}


@dataclass
class ReportSettings:
    warmup_s: float = 2.0                 # left out of error/force/latency figures
    free_force_threshold_n: float = 1.0   # free motion when |F| < 1 N ...
    free_hold_s: float = 0.2              # ... and has been for 0.2 s
    error_bound_m: float = 0.05           # x_b, the paper's bound (plotted)
    max_force_n: float | None = None      # F_max of the controller (plotted when known)
    joint_states_period_s: float = 0.001  # the simulator's physics step
    real_time_factor_target: float | None = None   # None: TARGETS' (a run profile's bound, from the launcher)
    # The quiet tail's start (a stamp, the run's quiet_from; None: no tail). The error and force figures describe
    # the task before it; the tail is the free-response test of the run verdict (docs/EXPERIMENTS.md).
    quiet_from: float | None = None

    def targets(self) -> dict[str, tuple[str, float]]:
        """TARGETS with this run's real-time-factor bound."""
        if self.real_time_factor_target is None:
            return dict(TARGETS)
        return {**TARGETS, "real_time_factor": (TARGETS["real_time_factor"][0], self.real_time_factor_target)}


@dataclass
class Analysis:
    """Metrics plus the time series the plots draw (times relative to t0)."""
    metrics: dict
    t0: float
    error_t: np.ndarray = field(default_factory=lambda: np.empty(0))
    error: np.ndarray = field(default_factory=lambda: np.empty(0))
    error_free: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=bool))
    contact_intervals: list[tuple[float, float]] = field(default_factory=list)
    latencies_ms: np.ndarray = field(default_factory=lambda: np.empty(0))


def _key_us(stamps: np.ndarray) -> np.ndarray:
    return np.round(stamps * 1e6).astype(np.int64)


def _tracking_error(data: BagData) -> tuple[np.ndarray, np.ndarray, str]:
    """|x_d - x_R| of the TCP position at the replica's pose stamps; falls back to FicState.error[0:3]."""
    if data.has("/replica/desired_pose") and data.has("/replica/tcp_pose"):
        desired, tcp = data.series["/replica/desired_pose"], data.series["/replica/tcp_pose"]
        order_d, order_r = np.argsort(desired.stamp, kind="stable"), np.argsort(tcp.stamp, kind="stable")
        d_t, r_t = desired.stamp[order_d], tcp.stamp[order_r]
        d_xyz = np.column_stack([desired.values[a][order_d] for a in "xyz"])
        r_xyz = np.column_stack([tcp.values[a][order_r] for a in "xyz"])
        common, i_d, i_r = np.intersect1d(_key_us(d_t), _key_us(r_t), return_indices=True)
        if len(common) >= max(2, len(r_t) // 2):  # the replica publishes both with one stamp per tick
            return r_t[i_r], np.linalg.norm(d_xyz[i_d] - r_xyz[i_r], axis=1), "poses"
        inside = (r_t >= d_t[0]) & (r_t <= d_t[-1])
        if inside.sum() >= 2:
            d_at_r = np.column_stack([np.interp(r_t[inside], d_t, d_xyz[:, k]) for k in range(3)])
            return r_t[inside], np.linalg.norm(d_at_r - r_xyz[inside], axis=1), "poses_interpolated"
    if data.has(FIC_STATE_TOPIC):
        fic = data.series[FIC_STATE_TOPIC]
        order = np.argsort(fic.stamp, kind="stable")
        error = np.column_stack([fic.values[a][order] for a in ("ex", "ey", "ez")])
        return fic.stamp[order], np.linalg.norm(error, axis=1), "fic_state"
    return np.empty(0), np.empty(0), "none"


def free_motion_flags(ft_t: np.ndarray, force: np.ndarray, threshold: float, hold: float) -> np.ndarray:
    """Per F/T sample: |F| < threshold now and at every sample of the last `hold` seconds (docs/EXPERIMENTS.md).

    The first `hold` seconds of the stream count as contact (not yet known to be free)."""
    if len(ft_t) == 0:
        return np.empty(0, dtype=bool)
    contact = force >= threshold
    last_contact = np.maximum.accumulate(np.where(contact, ft_t, ft_t[0]))
    return (~contact) & (ft_t - last_contact >= hold - 1e-9)


def _intervals(t: np.ndarray, flags: np.ndarray) -> list[tuple[float, float]]:
    """[start, end) times of the runs where flags is True."""
    if len(t) == 0:
        return []
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(float(t[s]), float(t[min(e, len(t) - 1)])) for s, e in zip(starts, ends)]


def _number(value) -> float | int | None:
    if value is None:
        return None
    if isinstance(value, (int, np.integer)):
        return int(value)
    value = float(value)
    return None if math.isnan(value) or math.isinf(value) else value


def analyse(data: BagData, settings: ReportSettings | None = None) -> Analysis:
    settings = settings or ReportSettings()
    series = data.series
    if data.has("/joint_states"):
        t0 = float(series["/joint_states"].stamp.min())
    else:
        starts = [s.stamp.min() for s in series.values() if len(s)]
        t0 = float(min(starts)) if starts else 0.0
    cut = t0 + settings.warmup_s
    m: dict = {}

    # Tracking error and free motion (docs/EXPERIMENTS.md, "Metrics").
    error_t, error, source = _tracking_error(data)
    if data.has("/ft_sensor/wrench"):
        ft = series["/ft_sensor/wrench"]
        order = np.argsort(ft.stamp, kind="stable")
        ft_t = ft.stamp[order]
        ft_force = np.linalg.norm(np.column_stack([ft.values[a][order] for a in ("fx", "fy", "fz")]), axis=1)
        ft_free = free_motion_flags(ft_t, ft_force, settings.free_force_threshold_n, settings.free_hold_s)
        index = np.searchsorted(ft_t, error_t, side="right") - 1
        error_free = np.where(index >= 0, ft_free[np.clip(index, 0, None)], False)
        contact_intervals = [(a - t0, b - t0) for a, b in _intervals(ft_t, ~ft_free)]
        after = ft_t >= cut
        m["peak_interaction_force_n"] = _number(ft_force[after].max()) if after.any() else None
    else:
        error_free = np.ones(len(error_t), dtype=bool)
        contact_intervals = []
        m["peak_interaction_force_n"] = None
    counted = (error_t >= cut) & (error_t < (settings.quiet_from if settings.quiet_from is not None else np.inf))
    free_errors, contact_errors = error[counted & error_free], error[counted & ~error_free]
    m["free_motion_error_max_m"] = _number(free_errors.max()) if len(free_errors) else None
    m["free_motion_error_rms_m"] = _number(np.sqrt(np.mean(free_errors ** 2))) if len(free_errors) else None
    m["contact_error_max_m"] = _number(contact_errors.max()) if len(contact_errors) else None

    # Limits: the replica's cumulative tick counters (module docstring), from its LimitStatus or its /diagnostics.
    m["limit_violations"], m["limit_shaped_ticks"], m["limit_counters_source"] = limit_counts(data)

    # Pipeline latency: the master sample's age at the control tick that first used it (FicState.master_age)
    # minus the channel's hold of that sample.
    held_by_stamp = data.deliveries.get("/replica/teleop_command", {})
    latencies, unmatched = [], 0
    if data.has(FIC_STATE_TOPIC):
        fic = series[FIC_STATE_TOPIC]
        order = np.argsort(fic.stamp, kind="stable")
        seen: set[int] = set()
        for _stamp, master_ns, age in zip(fic.stamp[order], fic.values["master_stamp_ns"][order],
                                         fic.values["master_age"][order]):
            master_ns = int(master_ns)
            if master_ns == 0 or master_ns in seen:
                continue
            seen.add(master_ns)
            if master_ns * 1e-9 + age < cut:  # first used during the warm-up
                continue
            held = held_by_stamp.get(master_ns)
            if held is None:
                unmatched += 1
                continue
            latencies.append((age - held) * 1e3)
    latencies_ms = np.array(latencies)
    m["pipeline_latency_p50_ms"] = _number(np.percentile(latencies_ms, 50)) if len(latencies_ms) else None
    m["pipeline_latency_p99_ms"] = _number(np.percentile(latencies_ms, 99)) if len(latencies_ms) else None

    # Real-time factor: sim time advanced / wall time, after the warm-up. /clock carries sim time in both of the
    # simulator's modes; /joint_states stamps are sim time only in lockstep (the node clock in realtime mode).
    clock_topic = "/clock" if data.has("/clock") else ("/joint_states" if data.has("/joint_states") else None)
    m["real_time_factor"] = None
    if clock_topic:
        clock = series[clock_topic]
        order = np.argsort(clock.log, kind="stable")
        stamps, logs = clock.stamp[order], clock.log[order]
        keep = stamps >= (cut if clock_topic == "/joint_states" else stamps[0] + settings.warmup_s)
        if keep.sum() >= 2 and logs[keep][-1] > logs[keep][0]:
            m["real_time_factor"] = _number((stamps[keep][-1] - stamps[keep][0]) / (logs[keep][-1] - logs[keep][0]))

    # Dropped joint states: stamps advance by one physics step per message; gaps count the missing ones.
    # Countable only when the stamps sit on the step grid (lockstep: sim time); in realtime mode they are the
    # robot node's clock and a gap is indistinguishable from a late step, so the figure is left out (null).
    m["dropped_joint_states"] = None
    if data.has("/joint_states"):
        js = series["/joint_states"]
        stamps = js.stamp[np.argsort(js.log, kind="stable")]
        period_ns = round(settings.joint_states_period_s * 1e9)
        offset_ns = np.round(stamps * 1e9).astype(np.int64) % period_ns
        on_grid = np.minimum(offset_ns, period_ns - offset_ns) <= 1000  # within 1 us of a step
        m["joint_states_on_step_grid"] = _number(on_grid.mean())
        if on_grid.mean() >= 0.99:
            steps = np.diff(stamps) / settings.joint_states_period_s
            missing = np.round(steps[steps > 0]) - 1
            m["dropped_joint_states"] = int(missing[missing > 0].sum())
            # Out of order: a stamp older than the one before it (another graph's states, a reordering). A
            # repeated stamp is the lockstep robot republishing a state whose answer is late (at t = 0 until the
            # replica's first answer: as long as the machine makes it), counted apart.
            m["joint_states_out_of_order"] = int(np.count_nonzero(steps < 0))
            m["joint_states_repeated"] = int(np.count_nonzero(steps == 0))

    m["recorder_lost_messages"] = (sum(data.lost_messages.values()) if data.lost_messages is not None else None)
    m["recorder_lost_by_topic"] = data.lost_messages

    # One-way delay the channel added on the forward direction.
    held = [h for topic in FORWARD_TOPICS for stamp_ns, h in data.deliveries.get(topic, {}).items()
            if stamp_ns * 1e-9 >= cut]
    m["delay_one_way_ms"] = _number(np.median(held) * 1e3) if held else None

    clock_series = series.get(clock_topic) if clock_topic else None
    m["duration_s"] = _number(clock_series.stamp.max() - clock_series.stamp.min()) if clock_series else None
    m["controller"] = data.controller or None

    # Extras.
    m["wall_duration_s"] = _number(data.last_log - data.first_log)
    m["warmup_s"] = settings.warmup_s
    m["tracking_error_source"] = source
    m["tracking_error_samples"] = int(counted.sum())
    m["free_motion_fraction"] = _number(error_free[counted].mean()) if counted.any() else None
    m["pipeline_latency_samples"] = len(latencies_ms)
    m["pipeline_latency_unmatched"] = unmatched
    if data.has(FIC_STATE_TOPIC):
        fic = series[FIC_STATE_TOPIC]
        after = fic.stamp >= cut
        m["energy_max_j"] = _number(fic.values["total_energy"][after].max()) if after.any() else None
        m["master_stale_ticks"] = int(np.count_nonzero(fic.values["master_stale"]))
        phases = np.column_stack([fic.values[f"phase_{a}"][after] for a in "xyz"])
        m["convergence_phase_fraction"] = _number((phases == 1).mean()) if after.any() else None
        # The replica's passivity observer (fic_core/passivity_observer.py), cumulative over the run: the last
        # message holds the run's figures (NaN margins: a bag from before the observer).
        last = int(np.argmax(fic.stamp))
        margin = fic.values["passivity_margin_min"][last]
        m["passivity_margin_min_j"] = _number(margin) if np.isfinite(margin) else None
        m["passivity_violation_ticks"] = int(fic.values["passivity_violation_ticks"][last]) \
            if np.isfinite(margin) else None
    m["channel_energy_generated_j"] = _number(channel_energy_generated(data))
    m.update(channel_port_metrics(data))
    m.update(exchanged_energy_metrics(data))
    if data.has(LIMIT_STATUS_TOPIC):
        limits = series[LIMIT_STATUS_TOPIC]
        last = np.argmax(limits.stamp)
        m["limit_counters"] = {"ticks": int(limits.values["ticks"][last]),
                               "violation_ticks": int(limits.values["violation_ticks"][last]),
                               "shaped_ticks": int(limits.values["shaped_ticks"][last]),
                               "limit_status_messages": len(limits)}
    m["message_counts"] = dict(sorted(data.counts.items()))
    m["topic_types"] = dict(sorted(data.types.items()))
    m["bag"] = str(data.path)
    m["bag_complete"] = data.complete
    m["thresholds"] = {"free_force_threshold_n": settings.free_force_threshold_n,
                       "free_hold_s": settings.free_hold_s, "error_bound_m": settings.error_bound_m,
                       "max_force_n": settings.max_force_n}
    m["targets"] = {name: {"target": f"{op} {value}", "met": _meets(m.get(name), op, value)}
                    for name, (op, value) in settings.targets().items()}
    m["not_measured"] = not_measured(data, m, source, error_t, counted, cut)
    return Analysis(metrics=m, t0=t0, error_t=error_t - t0, error=error, error_free=error_free,
                    contact_intervals=contact_intervals, latencies_ms=latencies_ms)


#: The replica's /diagnostics status whose values hold its cumulative tick counters (the replica node's statistics).
REPLICA_STATUS = "replica"


def limit_counts(data: BagData) -> tuple[int | None, int | None, str | None]:
    """(violation ticks, shaped ticks, where from) of the whole run: the replica's cumulative counters, from the
    last LimitStatus or the last "replica" /diagnostics record, whichever counted more ticks (a starved recorder may
    hold only the start of the LimitStatus stream; the replica publishes its /diagnostics once more as it stops). A
    bag whose LimitStatus has no counters (ticks all zero: recorded before the replica had a status_rate) counts
    the messages with flags set, one message a tick. (None, None, None) when the bag holds neither."""
    found: list[tuple[int, int, int, str]] = []   # (ticks, violations, shaped, source)
    if data.has(LIMIT_STATUS_TOPIC):
        limits = data.series[LIMIT_STATUS_TOPIC]
        order = np.argsort(limits.log, kind="stable")
        if np.any(limits.values["ticks"] > 0):
            found.append((int(limits.values["ticks"][order][-1]), int(limits.values["violation_ticks"][order][-1]),
                          int(limits.values["shaped_ticks"][order][-1]), LIMIT_STATUS_TOPIC))
        else:
            found.append((len(limits), int(np.count_nonzero(limits.values["violations"])),
                          int(np.count_nonzero(limits.values["shaping"])), LIMIT_STATUS_TOPIC))
    record = data.diagnostics.get(REPLICA_STATUS, {})
    try:
        found.append((int(record["ticks"]), int(record["violation_ticks"]), int(record["shaped_ticks"]),
                      f"/diagnostics ({REPLICA_STATUS})"))
    except (KeyError, ValueError):
        pass
    if not found:
        return None, None, None
    _, violations, shaped, source = max(found, key=lambda row: row[0])
    return violations, shaped, source


def not_measured(data: BagData, m: dict, source: str, error_t: np.ndarray, counted: np.ndarray,
                 cut: float) -> dict[str, str]:
    """Why each safety figure the report could not give is missing (a starved recorder keeps only part of a run):
    metric -> one line; empty when every one was measured."""
    span = m.get("duration_s")
    held = f"the bag holds {span:.1f} s of simulated time" if span is not None else "the bag holds no /clock"
    reasons = {}
    if m.get("free_motion_error_max_m") is None:
        if source == "none":
            reasons["free_motion_error_max_m"] = (
                "no tracking-error source in the bag (neither /replica/desired_pose with /replica/tcp_pose nor "
                f"{FIC_STATE_TOPIC}); {held}")
        elif not counted.any():
            reasons["free_motion_error_max_m"] = (
                f"all {len(error_t)} tracking-error samples lie in the {m['warmup_s']:g} s warm-up; {held}")
        else:
            reasons["free_motion_error_max_m"] = "every tracking-error sample after the warm-up was in contact"
        reasons["free_motion_error_rms_m"] = reasons["free_motion_error_max_m"]
    if m.get("limit_violations") is None:
        reasons["limit_violations"] = (f"no limit counters in the bag (neither {LIMIT_STATUS_TOPIC} nor the replica's "
                                       f"/diagnostics); {held}")
    if m.get("real_time_factor") is None:
        reasons["real_time_factor"] = f"fewer than two /clock (or /joint_states) stamps after the warm-up; {held}"
    return reasons


def port_energy(position_t: np.ndarray, positions: np.ndarray, force_t: np.ndarray,
                forces: np.ndarray) -> float:
    """Energy a motion port passes on, sum_k -F(t_k) . (x_k - x_{k-1}) [J], F held from its latest sample at t_k
    (zero before the first): the work the motion does against the force that comes back."""
    if len(position_t) < 2:
        return 0.0
    order = np.argsort(position_t, kind="stable")
    position_t, positions = position_t[order], positions[order]
    held = np.zeros_like(positions)
    if len(force_t):
        force_order = np.argsort(force_t, kind="stable")
        index = np.searchsorted(force_t[force_order], position_t, side="right") - 1
        valid = index >= 0
        held[valid] = forces[force_order][index[valid]]
    return float(np.sum(-held[1:] * np.diff(positions, axis=0)))


def channel_energy_generated(data: BagData) -> float | None:
    """Energy the delay channel generated, time-domain-passivity style, at its two ports [J].

    Master port: the offset x_d' the master sends (/master/teleop_command) against the force it receives
    (/master/feedback_wrench). Replica port: x_d' as the replica receives it (/replica/teleop_command) against the
    force the replica sends back (/replica/feedback_wrench). Each force is held from its latest sample, by log
    time (when it was seen). Generated = what leaves at the replica port minus what entered at the master port:
    positive when the delay turned less energy in into more energy out. None without those four topics. These are
    the signals before the channel ports' passivity controllers (TDPA) act: with them on, what got out is
    ``channel_observed_generated_j`` (channel_port_metrics).
    """
    series = data.series
    topics = ("/master/teleop_command", "/master/feedback_wrench", "/replica/teleop_command",
              "/replica/feedback_wrench")
    if not all(data.has(topic) for topic in topics):
        return None

    def offset(topic: str) -> tuple[np.ndarray, np.ndarray]:
        s = series[topic]
        return s.log, np.column_stack([s.values[f"offset_{a}"] for a in "xyz"])

    def force(topic: str) -> tuple[np.ndarray, np.ndarray]:
        s = series[topic]
        return s.log, np.column_stack([s.values[f"f{a}"] for a in "xyz"])

    entered = port_energy(*offset("/master/teleop_command"), *force("/master/feedback_wrench"))
    left = port_energy(*offset("/replica/teleop_command"), *force("/replica/feedback_wrench"))
    return left - entered


#: The channel ports' /diagnostics statuses (the master and the replica node).
CHANNEL_PORT_STATUSES = {"master": "master: channel port", "replica": "replica: channel port"}


def channel_port_metrics(data: BagData) -> dict:
    """The live observers' figures (module docstring, channel_ports), or nulls without their statuses."""
    found = {side: data.diagnostics.get(name) for side, name in CHANNEL_PORT_STATUSES.items()}
    if not all(found.values()):
        return {"channel_ports": None, "channel_forward_generated_j": None, "channel_backward_generated_j": None,
                "channel_observed_generated_j": None, "channel_port_negative_ticks": None}
    ports = {side: {key: _number(float(value)) for key, value in values.items()} for side, values in found.items()}
    master, replica = ports["master"], ports["replica"]
    return {"channel_ports": ports, "channel_forward_generated_j": replica["generated_j"],
            "channel_backward_generated_j": master["generated_j"],
            "channel_observed_generated_j": _number(master["output_energy_j"] + replica["output_energy_j"]
                                                    - master["input_energy_j"] - replica["input_energy_j"]),
            "channel_port_negative_ticks": int(master["negative_ticks"] + replica["negative_ticks"])}


#: The FIC ports' exchanged-energy statuses (the replica and the master node).
EXCHANGED_ENERGY_STATUSES = {"replica": "replica: exchanged energy", "master": "master: exchanged energy"}


def exchanged_energy_metrics(data: BagData) -> dict:
    """The exchanged-energy observers' last figures per side (module docstring)."""
    sides = {side: data.diagnostics.get(name) for side, name in EXCHANGED_ENERGY_STATUSES.items()}
    figures = {side: None if values is None else {key: _number(float(value)) for key, value in values.items()}
               for side, values in sides.items()}
    ticks = [int(values["violation_ticks"]) for values in figures.values() if values is not None]
    return {"exchanged_energy": figures, "exchanged_energy_violation_ticks": sum(ticks) if ticks else None}


def _meets(value, op: str, target: float) -> bool | None:
    if value is None:
        return None
    return {"<": value < target, "==": value == target, ">=": value >= target}[op]
