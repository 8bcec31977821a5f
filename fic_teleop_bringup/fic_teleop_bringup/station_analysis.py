"""What a two-station run (two_stations.py) measured about its link: stations.json in the run folder.

- traffic: bytes/s and RTPS samples/s per direction and topic crossing the veth (rtps_traffic.py), while the
  script runs (from 2 s after its start to the link cut or the end) and before it (discovery, start-up);
- link cut: when the link went down and up; the first teleoperation command the replica used after link-up
  (FicState.master_stamp changing to a command it had not used before; FicState comes at status_rate, 25 Hz,
  so 40 ms resolution) and whether that command was sent before the cut, during it (kept and resent by DDS) or
  after; the first message of each link stream after link-up; the master's and the replica's log lines about
  it; per station stream the longest gap inside and outside the cut, between the recorder's receive times and
  between the messages' header stamps (the recorder of each station should lose nothing of its own station's
  streams: a stamp gap is a sample not published or lost, a receive gap alone a late delivery); node logs with a
  traceback;
- clocks: the master stamps the teleoperation command on its clock and the replica ages it on its own, so the
  report's pipeline latency (FicState.master_age - held) holds the offset between the two clocks. Two figures do
  not: the robot-station part (the control tick that first used a command minus its delivery by the robot-side
  channel, both robot clock) and an offset estimate from the two directions (as NTP does), with the packet
  capture on the robot station's end of the link (kernel timestamps, robot clock) as the robot's side of both:
  forward, the master stamps each command when it sends it, so f = min(wire time - stamp) = (shortest transit
  master -> wire) - offset; backward, the master-side channel notes when each feedback wrench arrived, so
  b = min(received - wire time) = (shortest transit wire -> master) + offset. (The wrench's own stamp is the F/T
  sample's, which in realtime lags the robot's wall clock by however far the simulation fell behind, and the
  robot recorder's receive time lagged by up to 1.4 s on a loaded machine: neither is a send time.) The offset
  of the master's clock ahead of the robot's is (b - f) / 2, within +-(b + f) / 2 (both transits are >= 0).
  The corrected pipeline latency is the report's plus that offset.

All times are host wall-clock seconds: both namespaces share the host's clock, unless --station-clock-offset
shifted the master station's.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from fic_teleop_bringup.station_layout import StationLayout

DELIVERY_TOPICS = {"robot": "/channel/deliveries", "master": "/master_station/channel/deliveries"}
#: The streams whose longest gaps a link cut is judged by, each with the node that publishes it (docs/INTERFACES.md).
#: Which station a stream belongs to is its publisher's station in the run profile's layout (`station_streams`).
GAP_STREAM_PUBLISHERS = {"/joint_states": "robot", "/clock": "robot", "/ft_sensor/wrench": "robot",
                         "/replica/fic_state": "replica", "/replica/tcp_pose": "replica",
                         "/planner/desired_pose": "planner", "/replica/teleop_command": "channel_forward",
                         "/haptic/pose": "haptic_device", "/master/teleop_command": "master",
                         "/haptic/wrench_command": "master", "/master/feedback_wrench": "channel_backward"}


#: The gap streams whose header stamps are on the host's wall clock in realtime (the /clock message carries the
#: simulation's time): their stamp gaps say whether the publisher went on and the recorder lost nothing.
STAMPED_STREAMS = frozenset(GAP_STREAM_PUBLISHERS) - {"/clock"}


def station_streams(layout: StationLayout) -> dict[str, list[str]]:
    """{"robot": [...], "master": [...]}: each gap stream on the side of the station its publisher runs in, so a
    profile that moves a node moves its stream's statistics with it (its own station's recorder should lose none)."""
    streams: dict[str, list[str]] = {"robot": [], "master": []}
    for topic, publisher in GAP_STREAM_PUBLISHERS.items():
        streams[layout.station_of(publisher)].append(topic)
    return streams


def _seconds(time_msg) -> float:
    return time_msg.sec + 1e-9 * time_msg.nanosec


def read_bag(bag: Path, decode: set[str], stamped: frozenset[str] = frozenset()) -> dict:
    """Per topic: receive (log) times [s]; for the topics in `decode`, the decoded messages too; for those in
    `stamped`, the header stamps [s] read off the serialized messages (fic_teleop_runtime.cdr_header), in receive
    order. Read with the project's bag reader (fic_teleop_tools.recording.bag_reader): a finished bag from its
    indexes, a torn one sequentially up to its tail."""
    from mcap_ros2.decoder import DecoderFactory

    from fic_teleop_runtime.cdr_header import header_stamp, stamp_seconds
    from fic_teleop_tools.recording.bag_reader import read_indexed, read_messages

    def stamps_of(payloads) -> np.ndarray:
        stamps = (header_stamp(data) for data in payloads)
        return np.array([np.nan if stamp is None else stamp_seconds(stamp) for stamp in stamps])

    factory, decoders = DecoderFactory(), {}
    indexed = read_indexed(bag, set(decode) | set(stamped))
    if indexed is not None:   # a finished bag, from its indexes: the same times and messages for a tenth of the CPU
        decoded = {topic: indexed.decoded(topic, factory) for topic in decode if topic in indexed.payloads}
        return {"logs": {k: np.sort(v * 1e-9) for k, v in indexed.receive_times.items() if len(v)},
                "messages": {topic: [(log * 1e-9, message) for log, message in rows]
                             for topic, rows in decoded.items() if rows is not None},
                "stamps": {topic: stamps_of(data for _, data in indexed.payloads[topic])
                           for topic in stamped if topic in indexed.payloads}}
    logs: dict[str, list[float]] = {}
    messages: dict[str, list] = {}
    payloads: dict[str, list[bytes]] = {}
    for schema, channel, message in read_messages(bag):
        log = message.log_time * 1e-9
        logs.setdefault(channel.topic, []).append(log)
        if channel.topic in stamped:
            payloads.setdefault(channel.topic, []).append(message.data)
        if channel.topic in decode and schema is not None:
            if channel.id not in decoders:
                decoders[channel.id] = factory.decoder_for(channel.message_encoding, schema)
            messages.setdefault(channel.topic, []).append((log, decoders[channel.id](message.data)))
    return {"logs": {k: np.sort(np.array(v)) for k, v in logs.items()}, "messages": messages,
            "stamps": {topic: stamps_of(data) for topic, data in payloads.items()}}


def traffic_summary(capture: dict, start: float | None, end: float | None) -> dict:
    from fic_teleop_bringup.rtps_traffic import summarise
    summary = summarise(capture, start, end)
    totals = {direction: round(sum(e["bytes"] for e in topics.values()) / max((end - start), 1e-9), 1)
              if start is not None and end is not None else None for direction, topics in summary.items()}
    return {"window_s": None if start is None or end is None else round(end - start, 2),
            "per_topic": summary, "total_bytes_per_s": totals}


def _seconds_with(capture: dict, match, samples_only: bool = False) -> set[int]:
    return {second for topics in capture.get("directions", {}).values() for name, entry in topics.items()
            if match(name) for second, samples in zip(entry["seconds"], entry["samples"])
            if samples or not samples_only}


def _steady_window(capture: dict, cut_wall: float | None) -> tuple[float, float]:
    """[start, end) in whole wall seconds (see analyse_run); (0, 0) if there is none."""
    command = _seconds_with(capture, lambda name: name == "/master/teleop_command", samples_only=True)
    if not command:
        return 0.0, 0.0
    first, last = min(command), max(command)
    if cut_wall is not None:
        last = min(last, int(cut_wall) - 1)
    sedp = sorted(second for second in _seconds_with(capture, lambda name: name.startswith("discovery: SEDP"))
                  if first <= second <= last)
    bounds = [first - 1] + sedp + [last + 1]
    best = max(zip(bounds, bounds[1:]), key=lambda pair: pair[1] - pair[0])
    return float(best[0] + 1), float(best[1])


def _gap_stats(times: np.ndarray, window: tuple[float, float] | None) -> dict:
    if len(times) < 2:
        return {"messages": int(len(times))}
    gaps = np.diff(times)
    result = {"messages": int(len(times)), "longest_gap_s": round(float(gaps.max()), 4)}
    if window is not None:
        inside = (times[1:] >= window[0]) & (times[:-1] <= window[1])
        result["longest_gap_in_cut_s"] = round(float(gaps[inside].max()), 4) if inside.any() else None
        result["longest_gap_outside_cut_s"] = round(float(gaps[~inside].max()), 4) if (~inside).any() else None
        span = window[1] - window[0]
        in_window = np.count_nonzero((times >= window[0]) & (times < window[1]))
        result["rate_in_cut_hz"] = round(in_window / span, 1) if span > 0 else None
        before = times[(times >= window[0] - span) & (times < window[0])]
        result["rate_before_cut_hz"] = round(len(before) / span, 1) if span > 0 else None
    return result


def _stamp_gap_stats(stamps: np.ndarray, window: tuple[float, float]) -> dict:
    """The longest gaps between the header stamps of consecutive samples, inside and outside `window`: whether the
    publisher went on and the recorder lost nothing. A late delivery (the recorder not scheduled for a while on a
    loaded machine) leaves the stamps whole, so it shows in the receive-time gaps of `_gap_stats` alone."""
    stamps = np.sort(stamps[np.isfinite(stamps)])
    if len(stamps) < 2:
        return {}
    gaps = np.diff(stamps)
    inside = (stamps[1:] >= window[0]) & (stamps[:-1] <= window[1])
    return {"longest_stamp_gap_in_cut_s": round(float(gaps[inside].max()), 4) if inside.any() else None,
            "longest_stamp_gap_outside_cut_s": round(float(gaps[~inside].max()), 4) if (~inside).any() else None}


def deliveries(bag: dict, topic_key: str, route_topic: str) -> tuple[np.ndarray, list[int]]:
    """(stamp, received, held) of the channel's deliveries of one route [s], and their stamps in integer ns (the
    key that FicState.master_stamp matches exactly; a float second of 1.7e9 is only good to 0.2 us)."""
    rows, keys = [], []
    for _, m in bag["messages"].get(topic_key, []):
        if m.topic == route_topic:
            rows.append((_seconds(m.header.stamp), _seconds(m.received), float(m.held)))
            keys.append(m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec)
    return (np.array(rows) if rows else np.empty((0, 3))), keys


def _first_wire_time(capture: dict, topic: str) -> dict[int, float]:
    """Header stamp [ns] -> the first time a sample with it was on the wire (a resend comes later)."""
    first: dict[int, float] = {}
    for stamp, wire in capture.get("wire_times", {}).get(topic, []):
        first.setdefault(int(stamp), float(wire))
    return first


def clock_figures(robot: dict, master: dict, capture: dict, warmup_origin: float) -> dict:
    """The robot-station latency, the offset estimate and the corrected pipeline latency (module docstring)."""
    forward, forward_keys = deliveries(robot, DELIVERY_TOPICS["robot"], "/replica/teleop_command")
    backward, backward_keys = deliveries(master, DELIVERY_TOPICS["master"], "/master/feedback_wrench")
    command_wire = _first_wire_time(capture, "/master/teleop_command")
    wrench_wire = _first_wire_time(capture, "/replica/feedback_wrench")
    forward_apparent = np.array([wire - key * 1e-9 for key, wire in command_wire.items()])
    backward_apparent = np.array([r - wrench_wire[key] for key, (s_, r, h) in zip(backward_keys, backward)
                                  if key in wrench_wire])
    result: dict = {"forward_samples": int(len(forward_apparent)), "backward_samples": int(len(backward_apparent))}
    if len(forward_apparent):
        result["forward_apparent_transit_ms"] = {"min": round(float(forward_apparent.min()) * 1e3, 3),
                                                 "p50": round(float(np.median(forward_apparent)) * 1e3, 3)}
    if len(backward_apparent):
        result["backward_apparent_transit_ms"] = {"min": round(float(backward_apparent.min()) * 1e3, 3),
                                                  "p50": round(float(np.median(backward_apparent)) * 1e3, 3)}
    offset = None
    if len(forward_apparent) and len(backward_apparent):
        f, b = float(forward_apparent.min()), float(backward_apparent.min())
        offset = (b - f) / 2.0
        result["master_clock_ahead_estimate_ms"] = round(offset * 1e3, 3)
        result["estimate_bound_ms"] = round((b + f) / 2.0 * 1e3, 3)
    # The control tick that first used each command (FicState: master_stamp + master_age, robot clock).
    delivered_at = {key: r + h for key, (s, r, h) in zip(forward_keys, forward)}
    held_by = {key: h for key, (s, r, h) in zip(forward_keys, forward)}
    robot_part, stamp_based = [], []
    seen = set()
    for _, state in robot["messages"].get("/replica/fic_state", []):
        key = state.master_stamp.sec * 1_000_000_000 + state.master_stamp.nanosec
        if key == 0 or key in seen:
            continue
        seen.add(key)
        tick = _seconds(state.master_stamp) + state.master_age
        if tick < warmup_origin or key not in delivered_at:
            continue
        robot_part.append(tick - delivered_at[key])
        stamp_based.append(state.master_age - held_by[key])
    if robot_part:
        robot_part_ms, stamp_ms = np.array(robot_part) * 1e3, np.array(stamp_based) * 1e3
        result["robot_station_latency_ms"] = {"p50": round(float(np.percentile(robot_part_ms, 50)), 3),
                                              "p99": round(float(np.percentile(robot_part_ms, 99)), 3),
                                              "samples": len(robot_part)}
        result["stamp_based_latency_ms"] = {"p50": round(float(np.percentile(stamp_ms, 50)), 3),
                                            "p99": round(float(np.percentile(stamp_ms, 99)), 3)}
        if offset is not None:
            corrected = stamp_ms + offset * 1e3
            result["corrected_latency_ms"] = {"p50": round(float(np.percentile(corrected, 50)), 3),
                                              "p99": round(float(np.percentile(corrected, 99)), 3)}
    return result


def link_cut_figures(robot: dict, master: dict, events: dict, run_dir: Path, layout: StationLayout,
                     master_ahead_s: float = 0.0) -> dict:
    """`master_ahead_s`: the master station's clock offset (estimated), taken off its bag's receive times; `layout`:
    the run's stations (which station's bag holds each gap stream)."""
    down, up = events["down_wall"], events["up_wall"]
    result: dict = {"down_s": round(up - down, 3), "down_at_run_s": events.get("down_run_s")}
    master = {"logs": {topic: times - master_ahead_s for topic, times in master["logs"].items()},
              "stamps": {topic: stamps - master_ahead_s for topic, stamps in master.get("stamps", {}).items()}}
    states = [(s.header.stamp, s.master_stamp) for _, s in robot["messages"].get("/replica/fic_state", [])]
    used_before = {ms.sec * 1_000_000_000 + ms.nanosec for stamp, ms in states if _seconds(stamp) < up}
    last_before_cut = max((_seconds(ms) for stamp, ms in states if _seconds(stamp) < down), default=None)
    for stamp, ms in sorted(states, key=lambda pair: _seconds(pair[0])):
        key = ms.sec * 1_000_000_000 + ms.nanosec
        if _seconds(stamp) >= up and key and key not in used_before:
            command = _seconds(ms)
            result["first_command_used_after_up_s"] = round(_seconds(stamp) - up, 3)
            result["that_command_stamped_s_after_up"] = round(command - up, 3)
            result["that_command_was"] = ("sent during the cut, kept and resent by DDS" if down <= command < up
                                          else "sent after link-up" if command >= up else "sent before the cut")
            break
    if last_before_cut is not None:
        result["last_command_before_cut_stamped_s_before_down"] = round(down - last_before_cut, 3)
    for name, bag, topic in (("replica_teleop_command", robot, "/replica/teleop_command"),
                             ("master_feedback_wrench", master, "/master/feedback_wrench")):
        times = bag["logs"].get(topic, np.empty(0))
        after = times[times >= up]
        result[f"first_{name}_after_up_s"] = round(float(after[0] - up), 3) if len(after) else None
    window = (down, up)
    # Each stream from its own station's bag (bag/ for the robot station, bag_master/ for the master station's).
    for station, topics in station_streams(layout).items():
        bag = robot if station == "robot" else master
        result[f"{station}_station_streams"] = {
            t: {**_gap_stats(bag["logs"].get(t, np.empty(0)), window),
                **_stamp_gap_stats(bag.get("stamps", {}).get(t, np.empty(0)), window)} for t in topics}
    result["log_lines"] = _log_lines(run_dir / "logs")
    return result


LOG_PATTERNS = {"master": re.compile(r"feedback_wrench is stale.*"),
                "replica": re.compile(r"(no teleoperation command for more than.*|teleoperation commands are back.*)")}


def _log_lines(log_dir: Path) -> dict:
    lines: dict = {}
    for node, pattern in LOG_PATTERNS.items():
        path = log_dir / f"{node}.log"
        if path.exists():
            lines[node] = [m.group(0)[:160] for m in pattern.finditer(path.read_text(errors="replace"))][:6]
    crashed = [p.stem for p in log_dir.glob("*.log") if "Traceback (most recent call last)" in
               p.read_text(errors="replace")]
    lines["logs_with_a_traceback"] = crashed
    return lines


def analyse_run(run_dir: Path, outer_record: dict, layout: StationLayout) -> str:
    """stations.json of a finished run and the lines to print; ``layout``: the run profile's stations."""
    path = run_dir / "stations.json"
    record = json.loads(path.read_text()) if path.exists() else {}
    record.update(outer_record)
    origin = record.get("origin_wall")
    capture_path = run_dir / "link_capture.json"
    events = record.get("link_events") or {}
    lines = [f"[stations] run folder {run_dir}"]
    if capture_path.exists() and origin:
        capture = json.loads(capture_path.read_text())
        # Running: the longest stretch of whole seconds, while the command crosses and before any cut, with no
        # endpoint announcement (SEDP) in it: discovery is over and shutdown has not begun. On a loaded machine
        # start-up discovery goes on well into the script, and the run goes on well past origin + duration of
        # wall time (the simulation runs slower than real time).
        steady_start, steady_end = _steady_window(capture, events.get("down_wall"))
        record["traffic"] = {"running": traffic_summary(capture, steady_start, steady_end) if steady_end > steady_start
                             else {"window_s": 0, "per_topic": {}, "total_bytes_per_s": {}},
                             "before_the_script": traffic_summary(capture, None, float(int(origin))),
                             "whole_capture": traffic_summary(capture, None, None)}
        running = record["traffic"]["running"]
        for direction in ("master->robot", "robot->master"):
            topics = running["per_topic"].get(direction, {})
            top = sorted(topics.items(), key=lambda item: -item[1].get("bytes_per_s", 0))[:4]
            lines.append(f"[stations] {direction}: {running['total_bytes_per_s'].get(direction)} B/s; "
                         + ", ".join(f"{name} {entry.get('bytes_per_s')} B/s" for name, entry in top))
    robot_bag, master_bag = run_dir / "bag", run_dir / "bag_master"
    if robot_bag.exists() and master_bag.exists():
        streams = station_streams(layout)
        robot = read_bag(robot_bag, {"/channel/deliveries", "/replica/fic_state"},
                         STAMPED_STREAMS & set(streams["robot"]))
        master = read_bag(master_bag, {DELIVERY_TOPICS["master"]}, STAMPED_STREAMS & set(streams["master"]))
        capture = json.loads(capture_path.read_text()) if capture_path.exists() else {}
        record["clocks"] = clock_figures(robot, master, capture, (origin or 0.0) + 2.0)
        clocks = record["clocks"]
        if "robot_station_latency_ms" in clocks:
            lines.append(f"[stations] latency: stamp-based p50 {clocks['stamp_based_latency_ms']['p50']} ms, "
                         f"robot-station part p50 {clocks['robot_station_latency_ms']['p50']} ms, master clock ahead "
                         f"{clocks.get('master_clock_ahead_estimate_ms')} +- {clocks.get('estimate_bound_ms')} ms, "
                         f"corrected p50 {clocks.get('corrected_latency_ms', {}).get('p50')} ms")
        if "down_wall" in events and "up_wall" in events:
            ahead = (clocks.get("master_clock_ahead_estimate_ms") or 0.0) * 1e-3
            record["link_cut"] = link_cut_figures(robot, master, events, run_dir, layout, ahead)
            cut = record["link_cut"]
            lines.append(f"[stations] link cut {cut['down_s']} s: first command used "
                         f"{cut.get('first_command_used_after_up_s')}"
                         f" s after link-up ({cut.get('that_command_was')}); master: "
                         f"{len(cut['log_lines'].get('master', []))} stale-feedback line(s); tracebacks: "
                         f"{cut['log_lines']['logs_with_a_traceback'] or 'none'}")
    # What each station's recorder lost of its own topics (DDS's message-lost count in its bag's metadata.yaml,
    # "unknown" unless the recorder counted it: count_lost_messages is off by default, config/recorder.yaml).
    from fic_teleop_tools.report.bag_data import recorder_lost_messages

    record["recorder_lost_messages"] = {name: recorder_lost_messages(bag / "metadata.yaml")
                                        for name, bag in (("robot", robot_bag), ("master", master_bag))}
    lines.append("[stations] recorders lost: " + ", ".join(
        f"{name} {'unknown' if lost is None else (sum(lost.values()) if lost else 0)}"
        for name, lost in record["recorder_lost_messages"].items()))
    metrics_path = run_dir / "report" / "metrics.json"
    if metrics_path.exists():
        metrics = json.loads(metrics_path.read_text())
        record["metrics"] = {k: metrics.get(k) for k in (
            "free_motion_error_max_m", "free_motion_error_rms_m", "pipeline_latency_p50_ms", "pipeline_latency_p99_ms",
            "real_time_factor", "delay_one_way_ms", "limit_violations", "master_stale_ticks",
            "peak_interaction_force_n")}
    path.write_text(json.dumps(record, indent=2))
    lines.append(f"[stations] {path}")
    return "\n".join(lines)
