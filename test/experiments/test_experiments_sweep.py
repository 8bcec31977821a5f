"""The sweep machinery end to end at a small size: two lockstep E4 cells (FIC and the linear baseline at 200 ms)
through the real launcher and graph (every node a process, DDS between them), analysed from their bags.

Checks the machinery (both cells ran their simulated time, each has the run verdict, the
report's metrics and the limit counters, the summary JSON and the sweep plots exist) and the FIC cell's physics:
free-motion error within 1.5 x_b, no limit violation, and both cells STABLE by their quiet tail's free response.
The full sweeps (scripts/experiments.sh) stay outside the suite. 8.5 s of task per cell, then the quiet tail the
verdict needs at 200 ms and 1 s (10.4 s; paper_experiments.quiet_tail); the two cells cost 80 s of wall time at load 4
(2026-12-06), a lockstep cell of 4 s 15-60 s depending on the load.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
DURATION = 8.5


@pytest.mark.nodes
@pytest.mark.slow
@pytest.mark.timeout(720)
def test_two_cell_lockstep_sweep_writes_the_summary(tmp_path: Path):
    environment = dict(os.environ, ROS_LOG_DIR=str(tmp_path / "ros_log"), PYTHONUNBUFFERED="1")
    completed = subprocess.run(
        [sys.executable, "-m", "fic_teleop_experiments.paper_experiments", "--quick", "--sweep-duration", str(DURATION),
         "--runs", str(tmp_path / "runs"), "--results", str(tmp_path / "results")],
        env=environment, capture_output=True, text=True, timeout=700, cwd=REPO)
    assert completed.returncode == 0, completed.stdout[-3000:] + completed.stderr[-3000:]

    summary = json.loads((tmp_path / "results" / "summary.json").read_text())
    assert summary["time_mode"] == "lockstep" and summary["quick"] is True
    table = summary["experiments"]["E4"]["table"]
    assert sorted(row["controller"] for row in table) == ["fic", "linear"]
    for row in table:
        assert row["complete"], row
        # Judged by the free response in the quiet tail (a driven swing of the task no longer reads as an
        # oscillation): 2026-12-06, the FIC's x_d - x_R fell from 1.0 to 0.07 mm over the tail's 7 windows, the
        # linear law's from 0.5 mm to 0.1 um.
        assert row["stable"] is True, row
        assert 0.0 <= row["max_error_last_half_m"] < 5.0
        assert row["violation_ticks"] == 0, row
    # The physics of the FIC's cell (the E1 scene and delay, 4 s lockstep; two runs under a load average of 30 on
    # 2 cores, 2026-12-02, the second with the passive attractor and F_max = 10 N: stable, free-motion error max
    # 21.6 / 33.7 mm, RMS 11.8 / 12.6 mm; a fresh-clone suite on a quiet machine, 17:15: 53.4 mm, the last half
    # holding the operator's first avoid move): the error within 1.5 x_b = 75 mm, RMS within 25 mm (2x).
    fic = next(row for row in table if row["controller"] == "fic")
    assert fic["max_error_last_half_m"] < 0.075, fic
    cells = json.loads((tmp_path / "results" / "e4.json").read_text())["cells"]
    for cell in cells:
        if cell["controller"] == "fic":
            # Within 1.5 x_b, not x_b: this cell's free-motion error max was 45-90 mm while the lockstep followers could
            # trail the simulation by 30 ms (their 100 Hz x_d' stream then had holes the link hold reads as gaps);
            # 36.7 and 40.0 mm at 11 ms (2026-12-06, docs/RESULTS.md, "E1-E4"): two runs are too few to hold it to
            # x_b here. The paper's x_b is E1's claim, judged there.
            assert cell["metrics"]["free_motion_error_max_m"] < 0.075, cell["metrics"]
            assert cell["metrics"]["free_motion_error_rms_m"] < 0.025, cell["metrics"]
            assert cell["metrics"]["limit_violations"] == 0
        assert cell["launcher_exit_code"] == 0, cell
        # Nothing the recorder should have had is missing: no gap in /joint_states' 1 ms grid (DDS's message-lost
        # count is off by default, config/recorder.yaml; 18 /haptic/pose samples of a cell were once lost while the
        # writers kept only 20).
        assert cell["metrics"]["dropped_joint_states"] == 0, cell["metrics"]
        assert cell["controller"] == cell["labels"]["controller"]  # the replica ran the controller asked for
        assert cell["metrics"]["delay_one_way_ms"] == pytest.approx(200.0, abs=5.0)
        assert cell["stability"]["figures"]["duration_s"] > 0.5 * DURATION
        figures = cell["stability"]["figures"]
        assert figures["tail_s"] >= figures["tail_needed_s"] and figures["tail_windows"] >= 3, figures
        assert (Path(cell["run_dir"]) / "bag" / "metadata.yaml").exists()
    assert (tmp_path / "results" / "e4_delay_sweep.png").stat().st_size > 1000
    assert (tmp_path / "results" / "e4_stability_map.png").stat().st_size > 1000
    # Lockstep keeps the operator's side on simulated time: the nodes that only follow /clock publish on their own
    # period with distinct stamps (the EventsExecutor's timers fired in bursts with one stamp, then fell silent
    # for 100 ms), and the simulation never ran more than the peer barrier's lag ahead of them.
    for cell in cells:
        stamps = _header_stamps(Path(cell["run_dir"]) / "bag", PEER_TOPICS)
        for topic, values in stamps.items():
            gaps = [b - a for a, b in zip(values, values[1:])]
            assert len(values) > 0.5 * DURATION * 100, (topic, len(values))
            assert min(gaps) > 0.0, f"{topic}: repeated or reordered stamps"
            assert max(gaps) <= 0.06, f"{topic}: a {max(gaps) * 1000:.0f} ms silence"


PEER_TOPICS = ("/haptic/pose", "/master/teleop_command", "/planner/desired_pose")


def _header_stamps(bag: Path, topics) -> dict[str, list[float]]:
    """Header stamps of ``topics`` in the bag, in recording order, straight from the CDR bytes."""
    from mcap.reader import make_reader

    from fic_teleop_runtime.cdr_header import header_stamp, stamp_seconds
    from fic_teleop_tools.recording.bag_reader import mcap_file

    stamps: dict[str, list[float]] = {topic: [] for topic in topics}
    with open(mcap_file(bag), "rb") as stream:
        for _, channel, message in make_reader(stream).iter_messages(topics=list(topics)):
            stamp = header_stamp(message.data)
            if stamp is not None:
                stamps[channel.topic].append(stamp_seconds(stamp))
    return stamps
