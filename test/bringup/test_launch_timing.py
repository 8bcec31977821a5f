"""The launcher says when the machine was starved (fic_teleop_bringup/launch_timing.py): real-time factor, loop rates
and the replica's own loop against the realtime profile's bounds, its own exit code, and a broken safety figure still
wins."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from fic_teleop_bringup import run_profile
from fic_teleop_bringup.launch_supervision import (
    EXIT_CODES,
    EXIT_INPUT_REFUSED,
    EXIT_LIMIT_VIOLATIONS,
    EXIT_OK,
    EXIT_STARVED,
)
from fic_teleop_bringup.launch_timing import (
    LOOP_HEALTH_STATUS,
    SimulatedWindow,
    TimingBounds,
    exit_code,
    judge_run,
    recorded_in_window,
    timing_verdict,
)
from fic_teleop_bringup.workspace import PROFILES

BOUNDS = TimingBounds.from_profile(run_profile.read_layer(PROFILES / "realtime.yaml"))
REAL_TIME_FACTOR_BOUND, LOOP_RATE_BOUND = BOUNDS.real_time_factor, BOUNDS.loop_rate_fraction


def verdict(*arguments, **options):
    """The verdict against the realtime profile's bounds."""
    return timing_verdict(*arguments, bounds=BOUNDS, **options)


def rates(**fractions: float) -> dict[str, dict]:
    """Loop rates as fic_teleop_tools.report.loop_rates gives them, at 500 Hz nominal."""
    return {name.replace("_", " "): {"topic": f"/{name}", "nominal_hz": 500.0, "achieved_hz": 500.0 * fraction,
                                     "fraction": fraction} for name, fraction in fractions.items()}


QUIET = {"real_time_factor": 0.99}
HEALTHY = {"holds": "0", "held_ticks": "0", "max_state_age_ms": "6.1", "max_tick_gap_ms": "9.0"}


def test_a_run_that_kept_real_time_is_not_starved() -> None:
    timing = verdict(QUIET, rates(replica_control=0.99, planner=0.97), HEALTHY)
    assert timing.judged and not timing.starved and timing.reasons == []
    assert timing.figures["slowest_loop"] == "planner" and timing.figures["max_state_age_ms"] == 6.1
    assert timing.lines()[-1] == "the computer kept real time"
    assert exit_code(EXIT_OK, timing, EXIT_STARVED) == EXIT_OK


def test_a_simulation_that_did_not_run_its_duration_is_not_a_run_that_kept_real_time() -> None:
    """A physics thread stuck at t = 0 leaves no real-time factor and no bag span to judge, while the operator's side
    kept its rates and the replica its loop health; the wall-clock limit ended the run (measured once: "the computer
    kept real time", exit 0). Cut short by the user: not judged."""
    stuck = verdict({"real_time_factor": None}, rates(haptic_device=1.0), HEALTHY, simulated_s=0.0, asked_s=30.0)
    assert stuck.starved and stuck.reasons == ["the simulation ran 0.0 s of the 30 s asked"]
    assert exit_code(EXIT_OK, stuck, EXIT_STARVED) == EXIT_STARVED
    assert not verdict(QUIET, rates(replica_control=0.99), HEALTHY, simulated_s=29.99, asked_s=30.0).starved
    assert not verdict(QUIET, rates(replica_control=0.99), HEALTHY, simulated_s=5.0, asked_s=None).starved


def test_each_figure_out_of_its_bound_starves_the_run_and_is_named() -> None:
    slow_clock = verdict({"real_time_factor": REAL_TIME_FACTOR_BOUND - 0.01}, rates(replica_control=0.99),
                                HEALTHY)
    assert slow_clock.starved and slow_clock.reasons == ["real-time factor 0.940 < 0.95"]
    slow_loop = verdict(QUIET, rates(replica_control=LOOP_RATE_BOUND - 0.02, planner=0.99), HEALTHY)
    assert slow_loop.starved and slow_loop.reasons == ["loops below 90% of their rate: replica control 440 of 500 Hz"]
    held = verdict(QUIET, rates(replica_control=0.99), {**HEALTHY, "holds": "2",
                                                                "last_hold_reason": "state 61.0 ms old"})
    assert held.starved and held.figures["loop_holds"] == 2
    assert held.reasons == ["the replica held the arm 2 times in the run's window on its own loop's bounds (the "
                            "last: state 61.0 ms old)"]
    assert held.lines()[-1].startswith("STARVED: the machine did not keep real time")


def test_at_the_bounds_the_run_is_not_starved() -> None:
    timing = verdict({"real_time_factor": REAL_TIME_FACTOR_BOUND}, rates(replica_control=LOOP_RATE_BOUND),
                            HEALTHY)
    assert not timing.starved


def test_a_loop_with_no_message_is_not_this_graphs_and_unknown_figures_are_said() -> None:
    silent = rates(replica_control=0.99, master_force=0.0)
    timing = verdict(QUIET, silent, None)
    assert not timing.starved and timing.figures["slowest_loop"] == "replica control"
    assert "no loop-health record in the bag" in timing.lines()[2]
    assert not verdict(QUIET, {}, None).starved


def test_a_realtime_run_with_no_timing_figure_at_all_is_starved() -> None:
    """A bag without the replica's streams (a recorder starved before it wrote them) exited 0 before."""
    timing = verdict(None, {}, None)
    assert timing.starved and "no timing figure could be measured" in timing.lines()[-1]
    assert exit_code(0, timing, 6) == 6
    assert not verdict(None, {}, None, realtime=False).starved


def test_lockstep_is_not_judged() -> None:
    timing = verdict({"real_time_factor": 0.1}, rates(replica_control=0.2), {"holds": "3"}, realtime=False)
    assert not timing.judged and not timing.starved
    assert exit_code(EXIT_OK, timing, EXIT_STARVED) == EXIT_OK


def test_a_safety_failure_wins_over_starvation() -> None:
    starved = verdict({"real_time_factor": 0.7}, rates(replica_control=0.99), HEALTHY)
    assert exit_code(EXIT_OK, starved, EXIT_STARVED) == EXIT_STARVED
    for safety in (1, EXIT_LIMIT_VIOLATIONS, EXIT_INPUT_REFUSED):
        assert exit_code(safety, starved, EXIT_STARVED) == safety
    assert EXIT_STARVED not in (0, 1, 2, 3, 4, 5) and "starved" in EXIT_CODES[EXIT_STARVED]


def test_the_replicas_loop_health_record_is_read_from_the_bag(tmp_path: Path) -> None:
    """judge_run reads the last "replica loop health" record of the bag and writes timing.json."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from rclpy.serialization import serialize_message

    from fic_teleop_tools.recording.bag_writer import BagWriter

    writer = BagWriter(tmp_path / "bag")
    writer.add_topic("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray")
    for k, holds in enumerate(("0", "1")):
        values = {**HEALTHY, "holds": holds, "last_hold_reason": "control ticks 55.0 ms apart"}
        writer.write("/diagnostics", serialize_message(DiagnosticArray(status=[DiagnosticStatus(
            name=LOOP_HEALTH_STATUS, values=[KeyValue(key=key, value=v) for key, v in values.items()])])),
            (k + 1) * 1_000_000_000)
    writer.finish()
    timing = judge_run(tmp_path, tmp_path / "bag", QUIET, BOUNDS, realtime=True)
    assert timing.starved and timing.figures["loop_holds"] == 1
    assert json.loads((tmp_path / "timing.json").read_text())["starved"] is True


def test_a_bag_that_holds_only_part_of_the_run_is_starved() -> None:
    """A starved recorder kept 3.8 s of a 15 s run (measured at 70 % of one CPU): every other figure would describe
    that part alone."""
    partial = verdict(QUIET, rates(replica_control=0.99), HEALTHY, recorded_s=3.8, simulated_s=15.0)
    assert partial.starved and partial.reasons == ["the bag holds 3.8 s of the run's 15.0 s simulated (the recorder "
                                                   "fell behind)"]
    whole = verdict(QUIET, rates(replica_control=0.99), HEALTHY, recorded_s=15.0, simulated_s=15.0)
    assert not whole.starved and "the bag holds 15.0 s of the run's 15.0 s simulated" in whole.lines()[2]
    nan_rates = {"planner": {"topic": "/planner/desired_pose", "nominal_hz": 100.0, "achieved_hz": float("nan"),
                             "fraction": float("nan")}}
    assert verdict(QUIET, nan_rates, HEALTHY).figures.get("slowest_loop") is None


def test_the_bags_share_is_of_the_runs_window_on_the_simulations_clock() -> None:
    """A 6 s run (--duration 6) whose script starts 4 s after the graph: the launcher counts 3.8 to 9.8 s of simulated
    time, the recorder (started with the graph) holds /clock from 0 to 10.4 s. The share is the window's 6.0 of 6.0 s,
    not the bag's whole 10.4 s span ("9.8 s of the 6.0 s" was printed before)."""
    window = SimulatedWindow(3.8, 9.8)
    whole_bag = np.round(np.arange(0.0, 10.4, 0.01), 2)            # /clock at 100 Hz, start margin and shutdown too
    assert abs(window.length_s - 6.0) < 1e-9 and abs(recorded_in_window(whole_bag, window) - 6.0) < 1e-9
    lost_tail = whole_bag[whole_bag <= 5.0]                        # a recorder that stopped writing at 5 s
    assert abs(recorded_in_window(lost_tail, window) - 1.2) < 1e-9
    late_start = whole_bag[whole_bag >= 8.0]                       # one that wrote nothing before 8 s
    assert abs(recorded_in_window(late_start, window) - 1.8) < 1e-9
    assert recorded_in_window(np.empty(0), window) == 0.0
    starved = verdict(QUIET, rates(replica_control=0.99), HEALTHY, recorded_s=recorded_in_window(lost_tail, window),
                      simulated_s=window.length_s)
    assert starved.starved and "the bag holds 1.2 s of the run's 6.0 s simulated" in starved.reasons[0]


def test_judge_run_reads_the_bags_clock_for_its_share(tmp_path: Path) -> None:
    """judge_run reads the bag's /clock stamps and judges their part of the run's window."""
    from builtin_interfaces.msg import Time
    from rclpy.serialization import serialize_message
    from rosgraph_msgs.msg import Clock

    from fic_teleop_tools.recording.bag_writer import BagWriter

    writer = BagWriter(tmp_path / "bag")
    writer.add_topic("/clock", "rosgraph_msgs/msg/Clock")
    for k in range(0, 500):                                         # 0 to 4.99 s of simulated time at 100 Hz
        writer.write("/clock", serialize_message(Clock(clock=Time(sec=k // 100, nanosec=(k % 100) * 10_000_000))),
                     1_000_000_000 + k * 10_000_000)
    writer.finish()
    timing = judge_run(tmp_path, tmp_path / "bag", QUIET, BOUNDS, realtime=True, window=SimulatedWindow(3.8, 9.8))
    assert abs(timing.figures["recorded_s"] - 1.19) < 1e-6 and timing.figures["simulated_s"] == 6.0
    assert timing.starved and "the recorder fell behind" in timing.reasons[0]


def test_one_pass_gives_what_each_verdict_read_on_its_own(tmp_path: Path) -> None:
    """run_bag.scan (the launcher's one pass over the bag) gives the loops' receive times, the /clock stamps and the
    safety and loop-health records exactly as the verdicts' own readers do."""
    from builtin_interfaces.msg import Time
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from rclpy.serialization import serialize_message
    from rosgraph_msgs.msg import Clock
    from std_msgs.msg import Float64MultiArray

    from fic_teleop_bringup.launch_supervision import SAFETY_RECORDS, diagnostics_records
    from fic_teleop_bringup.launch_timing import JUDGED_RECORDS
    from fic_teleop_bringup.run_bag import scan
    from fic_teleop_tools.recording.bag_writer import BagWriter
    from fic_teleop_tools.report.loop_rates import loop_rates, loop_topics

    writer = BagWriter(tmp_path / "bag")
    for topic, kind in (("/clock", "rosgraph_msgs/msg/Clock"), ("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray"),
                        ("/effort_controller/commands", "std_msgs/msg/Float64MultiArray")):
        writer.add_topic(topic, kind)
    for k in range(1000):                                   # 10 s: /clock at 100 Hz, commands at 90 Hz
        log = 1_000_000_000 + k * 10_000_000
        writer.write("/clock", serialize_message(Clock(clock=Time(sec=k // 100, nanosec=(k % 100) * 10_000_000))), log)
        if k % 10:
            writer.write("/effort_controller/commands", serialize_message(Float64MultiArray(data=[0.0] * 7)), log)
        if k % 100 == 0:
            statuses = [DiagnosticStatus(name="replica", values=[KeyValue(key="input_safe_hold", value="no"),
                                                                 KeyValue(key="ticks", value=str(k))]),
                        DiagnosticStatus(name=LOOP_HEALTH_STATUS, values=[KeyValue(key="holds", value=str(k // 500))])]
            writer.write("/diagnostics", serialize_message(DiagnosticArray(status=statuses)), log)
    writer.finish()
    bag = tmp_path / "bag"
    scanned = scan(bag, loop_topics(None), JUDGED_RECORDS)
    assert {name: scanned.diagnostics[name] for name in SAFETY_RECORDS if name in scanned.diagnostics} == \
        diagnostics_records(bag, SAFETY_RECORDS) == {"replica": {"input_safe_hold": "no", "ticks": "900"}}
    assert scanned.diagnostics[LOOP_HEALTH_STATUS] == {"holds": "1"}
    assert len(scanned.clock_stamps) == 1000 and scanned.clock_stamps[-1] == 9.99
    assert loop_rates(bag, receive_times=(scanned.receive_times, scanned.span)) == loop_rates(bag)
    assert abs(loop_rates(bag)["replica control"]["achieved_hz"] - 90.0) < 1.0


def test_a_hold_before_the_operators_start_is_named_but_does_not_starve_the_run(tmp_path: Path) -> None:
    """Every hold that made a quiet run exit 6 on 2026-12-07 came 64-340 ms after the replica's first joint state,
    before the operator's start, while the other processes were still starting: the arm at rest and held, no figure
    of the run touched. Judged like every other timing figure, over the run's window: named, not a reason. A hold
    inside the window still starves the run, and a bag with no record before the window counts every hold in it."""
    from builtin_interfaces.msg import Time
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from rclpy.serialization import serialize_message
    from rosgraph_msgs.msg import Clock

    from fic_teleop_tools.recording.bag_writer import BagWriter

    def bag(folder: Path, holds_by_second: dict[int, str]) -> Path:
        writer = BagWriter(folder / "bag")
        writer.add_topic("/clock", "rosgraph_msgs/msg/Clock")
        writer.add_topic("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray")
        for k in range(1000):                          # 10 s of /clock at 100 Hz, received from 1 s on
            log = 1_000_000_000 + k * 10_000_000
            writer.write("/clock", serialize_message(Clock(clock=Time(sec=k // 100, nanosec=(k % 100) * 10_000_000))),
                         log)
            if k % 100 == 50 and k // 100 in holds_by_second:   # the 1 Hz loop-health record, half a second later
                values = {**HEALTHY, "holds": holds_by_second[k // 100], "last_hold_reason": "ticks 57.6 ms apart"}
                writer.write("/diagnostics", serialize_message(DiagnosticArray(status=[DiagnosticStatus(
                    name=LOOP_HEALTH_STATUS, values=[KeyValue(key=key, value=v) for key, v in values.items()])])), log)
        writer.finish()
        return folder / "bag"

    window = SimulatedWindow(3.8, 9.9)     # the operator's script from 3.8 s of simulated time
    for name, holds, starved, before in (("start-up", {0: "1", 1: "1", 5: "1", 9: "1"}, False, 1),
                                         ("in the window", {0: "0", 1: "0", 5: "1", 9: "1"}, True, 0),
                                         ("both", {0: "1", 5: "2", 9: "2"}, True, 1),
                                         ("no early record", {5: "1", 9: "1"}, True, 0)):
        folder = tmp_path / name.replace(" ", "_")
        folder.mkdir()
        timing = judge_run(folder, bag(folder, holds), QUIET, BOUNDS, realtime=True, window=window)
        assert timing.starved is starved, (name, timing.reasons)
        assert timing.figures["loop_holds_before_window"] == before, name
        line = next(text for text in timing.lines() if text.startswith("replica loop:"))
        assert ("before the operator's start" in line) is bool(before), (name, line)
        if starved:
            assert "in the run's window" in timing.reasons[-1], (name, timing.reasons)
