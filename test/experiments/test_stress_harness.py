"""The starvation harness's reading of a run (fic_teleop_experiments/tools/stress.py), without a run: the runaway
figures from a bag's joint states, the per-level summary, the levels and the refusals. The throttled run itself:
test/nodes/test_starved_run.py."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fic_teleop_experiments.tools.stress import CpuQuota, StressError, level_summary, parse_levels, runaway_figures

NOMINAL = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]


def _bag(path: Path, velocities: list[list[float]]) -> Path:
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    from fic_teleop_tools.recording.bag_writer import BagWriter

    writer = BagWriter(path)
    writer.add_topic("/joint_states", "sensor_msgs/msg/JointState")
    for k, velocity in enumerate(velocities):
        state = JointState(name=[f"panda_joint{j + 1}" for j in range(7)], position=NOMINAL, velocity=velocity)
        writer.write("/joint_states", serialize_message(state), (k + 1) * 1_000_000)
    writer.finish()
    return path


def test_a_joint_over_its_datasheet_speed_is_a_runaway(tmp_path: Path) -> None:
    calm = [[0.1] * 7] * 20
    quiet = runaway_figures(_bag(tmp_path / "calm", calm), {"free_motion_error_max_m": 0.03,
                                                              "thresholds": {"error_bound_m": 0.05}})
    assert not quiet["runaway"] and quiet["joint_states"] == 20
    assert quiet["max_joint_speed_ratio"] == pytest.approx(0.1 / 2.175, abs=1e-3)
    assert 0.0 < quiet["max_kinetic_energy_j"] < quiet["kinetic_energy_bound_j"]
    fast = calm[:10] + [[0.0, 11.0, 0.0, 0.0, 0.0, 0.0, 0.0]] + calm[:9]   # joint 2 at 11 rad/s
    swung = runaway_figures(_bag(tmp_path / "fast", fast), {"free_motion_error_max_m": 0.03})
    assert swung["runaway"] and swung["fastest_joint"] == 2
    assert swung["reasons"][0].startswith("joint 2 at 5.06 x its datasheet speed")
    assert any(reason.startswith("kinetic energy") for reason in swung["reasons"])


def test_a_free_motion_error_over_four_x_b_with_a_still_arm_is_lost_tracking_not_a_runaway(tmp_path: Path) -> None:
    """A held arm stays put while its set point moves on: the error is reported, the arm did not run away."""
    figures = runaway_figures(_bag(tmp_path / "calm", [[0.0] * 7] * 5), {"free_motion_error_max_m": 0.21,
                                                                          "thresholds": {"error_bound_m": 0.05}})
    assert not figures["runaway"] and figures["reasons"] == []
    assert figures["lost_tracking"] and figures["lost_tracking_reason"] == "free-motion error 210 mm > 4 x_b"
    assert not runaway_figures(_bag(tmp_path / "near", [[0.0] * 7] * 5),
                               {"free_motion_error_max_m": 0.19})["lost_tracking"]


def test_the_level_summary_counts_and_spreads() -> None:
    rows = [{"exit_code": 6, "flagged_starved": True, "runaway": False, "limit_violations": 0, "holds": None,
             "real_time_factor": 0.9, "slowest_loop_fraction": 0.5, "recorded_fraction": 1.1,
             "free_motion_error_max_m": 0.04, "free_motion_error_rms_m": 0.01, "max_joint_speed_ratio": 0.3,
             "max_kinetic_energy_j": 0.2},
            {"exit_code": 3, "flagged_starved": True, "runaway": True, "limit_violations": 12, "holds": None,
             "real_time_factor": 0.7, "slowest_loop_fraction": 0.2, "recorded_fraction": 0.4,
             "free_motion_error_max_m": 0.3, "free_motion_error_rms_m": 0.1, "max_joint_speed_ratio": 1.4,
             "max_kinetic_energy_j": 30.0}]
    summary = level_summary(rows)
    assert (summary["runs"], summary["runaways"], summary["runs_with_violations"], summary["flagged_starved"]) == \
        (2, 1, 1, 2)
    assert summary["runs_with_holds"] is None and summary["violations_where_held"] is None   # no record: unknown
    assert summary["exit_codes"] == [3, 6]
    assert summary["real_time_factor"] == [0.7, 0.8, 0.9]
    assert summary["free_motion_error_max_mm"] == [40.0, 170.0, 300.0]
    rows[1]["holds"] = 4
    assert level_summary(rows)["violations_where_held"] == 1


def test_levels_and_refusals() -> None:
    assert parse_levels("150, 100,70%,none") == [150.0, 100.0, 70.0, None]
    for level in (0.5, float("nan"), 1e6):
        with pytest.raises(StressError, match="CPU level"):
            CpuQuota(level)
    with pytest.raises(StressError, match="period"):
        CpuQuota(50.0, period_us=10)
    assert np.isfinite(parse_levels("25")[0])


def test_a_velocity_reflex_trip_in_the_robots_log_is_a_runaway_without_a_bag(tmp_path: Path) -> None:
    from fic_teleop_experiments.tools.stress import run_figures

    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "robot.log").write_text(
        "[INFO] [1.0] [robot]: robot_sim ready\n"
        "[ERROR] [2.0] [robot]: reflex: panda_joint6 moved at 2.871 rad/s, beyond its limit 2.610 rad/s by more "
        "than 10%\n")
    row = run_figures(tmp_path, 3)
    assert row["runaway"] is True and row["reflex_trips"] == 1
    assert any("panda_joint6 moved at 2.871" in reason for reason in row["reasons"])
    assert "no bag" not in row["reasons"]
    (logs / "robot.log").write_text("[INFO] [1.0] [robot]: robot_sim ready\n")
    quiet = run_figures(tmp_path, 1)
    assert quiet["runaway"] is None and quiet["reflex_trips"] == 0
