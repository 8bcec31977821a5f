"""Achieved rate of every loop of a recorded run, as a fraction of its nominal rate.

Each loop is judged by the stream it publishes once per iteration, counted over the bag's receive times (the
recorder's clock, so a loop that runs late shows up as a lower rate whatever its own stamps say):

- robot physics: /joint_states (one per 1 ms step);
- haptic device: /haptic/pose (``publish_rate_hz``);
- master force loop: /haptic/wrench_command (``control_rate``); master network loop: /master/teleop_command
  (``network_rate``);
- planner: /planner/desired_pose (``publish_rate``);
- replica control loop: /effort_controller/commands (``control_rate``: one torque command per control tick);
- forward channel: /replica/teleop_command, delivered at the master's ``network_rate`` (rate cap 0).

The nominal rate is the one the run was started with: the launcher's per-node overrides in ``<run>/params`` over
config/*.yaml. The first ``skip_s`` and the last ``tail_s`` seconds are left out (start-up and stop).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from fic_teleop_runtime.parameters import file_sections

from sim_bridge.recording.bag_reader import read_messages

REPO = Path(__file__).resolve().parents[3]


@dataclass(frozen=True)
class Loop:
    name: str
    topic: str
    params_file: str          # config/<file> and <run>/params/<file>
    parameter: str | None     # its rate parameter; None: a fixed rate
    fixed_rate_hz: float = 0.0


LOOPS = (
    Loop("robot physics", "/joint_states", "robot.yaml", None, 1000.0),
    Loop("haptic device", "/haptic/pose", "haptic_device.yaml", "publish_rate_hz"),
    Loop("master force", "/haptic/wrench_command", "master.yaml", "control_rate"),
    Loop("master network", "/master/teleop_command", "master.yaml", "network_rate"),
    Loop("planner", "/planner/desired_pose", "planner.yaml", "publish_rate"),
    Loop("replica control", "/effort_controller/commands", "replica.yaml", "control_rate"),
    Loop("forward channel", "/replica/teleop_command", "master.yaml", "network_rate"),
)


def _parameters(path: Path) -> dict:
    """Every section's values of a params file, read as rcl reads it (none if there is no such file)."""
    merged: dict = {}
    if path.exists():
        for values in file_sections(path).values():
            merged.update(values)
    return merged


def nominal_rate(loop: Loop, run_dir: Path | None) -> float:
    """The loop's rate as started: the run's override, else config/."""
    if loop.parameter is None:
        return loop.fixed_rate_hz
    values = _parameters(REPO / "config" / loop.params_file)
    if run_dir is not None:
        values.update(_parameters(run_dir / "params" / loop.params_file))
    return float(values[loop.parameter])


def loop_rates(bag: Path, run_dir: Path | None = None, skip_s: float = 3.0, tail_s: float = 1.0) -> dict[str, dict]:
    """{loop: {topic, nominal_hz, achieved_hz, fraction}} of one bag (module docstring)."""
    topics = {loop.topic for loop in LOOPS}
    times: dict[str, list[int]] = {topic: [] for topic in topics}
    for _, channel, message in read_messages(bag):
        if channel.topic in topics:
            times[channel.topic].append(message.log_time)
    every = [t for series in times.values() for t in series]
    if not every:
        return {}
    start, end = min(every) + skip_s * 1e9, max(every) - tail_s * 1e9
    rates: dict[str, dict] = {}
    for loop in LOOPS:
        stamps = np.asarray(times[loop.topic], dtype=np.int64)
        inside = stamps[(stamps >= start) & (stamps <= end)]
        nominal = nominal_rate(loop, run_dir)
        achieved = len(inside) / ((end - start) * 1e-9) if end > start else float("nan")
        rates[loop.name] = {"topic": loop.topic, "nominal_hz": nominal, "achieved_hz": round(achieved, 1),
                            "fraction": round(achieved / nominal, 3) if nominal > 0 else None}
    return rates
