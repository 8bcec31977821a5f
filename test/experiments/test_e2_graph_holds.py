"""The E2 graph trials' account of the robot's stale-command holds (fic_teleop_experiments.e2.graph.stale_holds): for
each hold, the wall time the simulation took for the watchdog's bound before it and the replica's commands in that
span, from the bag's receive times and the robot's log."""
from __future__ import annotations

import struct
from pathlib import Path

from mcap.writer import Writer

from fic_core import command_stamp
from fic_teleop_experiments.e2.graph import pace, stale_holds

EPOCH = 1_800_000_000.0   # [s] wall clock of the run's first step


def _write_run(out: Path, step_wall: list[float], commands_wall: list[float], hold_walls: list[float],
               command_states_ns: list[int] | None = None) -> None:
    """A run folder: /clock one message a simulated ms at the given wall times, the replica's commands (naming the
    states of ``command_states_ns``, if given), and a robot log with one stale hold at each of ``hold_walls``."""
    (out / "bag").mkdir(parents=True)
    (out / "logs").mkdir()
    with (out / "bag" / "bag_0.mcap").open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema(name="rosgraph_msgs/msg/Clock", encoding="ros2msg", data=b"")
        clock = writer.register_channel(topic="/clock", message_encoding="cdr", schema_id=schema)
        command = writer.register_channel(topic="/effort_controller/commands", message_encoding="cdr",
                                          schema_id=schema)
        for step, wall in enumerate(step_wall):
            data = b"\x00\x01\x00\x00" + struct.pack("<iI", step // 1000, (step % 1000) * 1_000_000)
            writer.add_message(clock, log_time=int(wall * 1e9), data=data, publish_time=int(wall * 1e9))
        for index, wall in enumerate(commands_wall):
            label = b"" if command_states_ns is None else command_stamp.label(command_states_ns[index]).encode()
            data = b"\x00\x01\x00\x00\x01\x00\x00\x00" + struct.pack("<I", len(label) + 1) + label + b"\x00"
            writer.add_message(command, log_time=int(wall * 1e9), data=data, publish_time=int(wall * 1e9))
        writer.finish()
    lines = [f"[WARN] [{wall:.9f}] [robot]: watchdog: torque commands stale (0.050 s > 0.050 s): holding the arm"
             for wall in hold_walls]
    (out / "logs" / "robot.log").write_text("\n".join(lines) + "\n")


def test_a_hold_after_slow_steps_shows_their_wall_time_and_the_late_answers(tmp_path: Path) -> None:
    # 200 simulated ms: 5 ms of wall a step, except steps 100-149 which each took 60 ms (past the lockstep timeout).
    walls, wall = [], EPOCH
    for step in range(200):
        wall += 0.06 if 100 <= step < 150 else 0.005
        walls.append(wall)
    hold_wall = walls[149] + 0.001
    late = [walls[100] + 0.5, walls[120] + 0.3, walls[140]]   # three late answers inside the slow span
    _write_run(tmp_path, walls, late, [hold_wall], [109_000_000, 128_000_000, 140_000_000])
    holds = stale_holds(tmp_path)
    assert len(holds) == 1
    assert abs(holds[0]["t_s"] - 0.149) < 0.002
    assert 2.8 < holds[0]["wall_s_for_bound"] < 3.1   # 50 steps at 60 ms
    assert holds[0]["commands_in_bound"] == 3
    assert abs(holds[0]["newest_state_age_ms"] - 9.0) < 2.0   # the newest answered the state of 140 ms
    assert abs(pace(tmp_path)["wall_ms_per_simulated_ms"] - (149 * 5.0 + 50 * 60.0) / 199) < 0.05


def test_a_run_without_holds_or_bag_has_none(tmp_path: Path) -> None:
    assert stale_holds(tmp_path) == []
    _write_run(tmp_path / "run", [EPOCH + 0.001 * step for step in range(10)], [], [])
    assert stale_holds(tmp_path / "run") == []
