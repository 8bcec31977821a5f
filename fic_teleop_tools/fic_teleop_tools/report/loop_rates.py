"""Achieved rate of every loop of a recorded run, as a fraction of its nominal rate.

Each loop is judged by the stream it publishes once per iteration, counted over the bag's receive times (the
recorder's clock, so a loop that runs late shows up as a lower rate whatever its own stamps say):

- robot physics: /joint_states (one per 1 ms step; realtime: ``joint_state_rate_hz``, 500 Hz under the launcher);
- haptic device: /haptic/pose (``publish_rate_hz``);
- master force loop: /haptic/wrench_command (``control_rate``); master network loop: /master/teleop_command
  (``network_rate``);
- planner: /planner/desired_pose (``publish_rate``);
- replica control loop: /effort_controller/commands (``control_rate``: one torque command per control tick);
- forward channel: /replica/teleop_command, delivered at the master's ``network_rate`` (rate cap 0).

The nominal rate is the one the run was started with: the launcher's per-node overrides in ``<run>/params`` over
config/*.yaml. The first ``skip_s`` and the last ``tail_s`` seconds are left out (start-up and stop).

Under the driver twins (``--hardware-twin``) the robot's physics shows on the franka_ros2 broadcaster's
/franka/joint_states (/joint_states is the 30 Hz joint_state_publisher) and the device's loop on /fd/ee_pose; in a
two-station run the master station's loops are in its own bag (``<run>/bag_master``), each rate counted over the
span of the bag that holds it (its own station's clock).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fic_teleop_runtime.driver_topics import ForceDimensionTopics, FrankaRos2Topics
from fic_teleop_runtime.parameters import file_sections
from fic_teleop_runtime.workspace import config_folder
from fic_teleop_tools.recording.bag_reader import read_messages


@dataclass(frozen=True)
class Loop:
    name: str
    topic: str
    params_file: str          # config/<file> and <run>/params/<file>
    parameter: str            # its rate parameter
    # Under a driver twin (``driver_interface`` in its params file): the driver's stream that shows the loop
    driver_interface: str | None = None
    driver_topic: str | None = None


LOOPS = (
    Loop("robot physics", "/joint_states", "robot.yaml", "joint_state_rate_hz",
         driver_interface="franka_ros2", driver_topic=FrankaRos2Topics.joint_states),
    Loop("haptic device", "/haptic/pose", "haptic_device.yaml", "publish_rate_hz",
         driver_interface="forcedimension", driver_topic=ForceDimensionTopics.ee_pose),
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
    values = _parameters(config_folder() / loop.params_file)
    if run_dir is not None:
        values.update(_parameters(run_dir / "params" / loop.params_file))
    return float(values[loop.parameter])


def joint_states_period(run_dir: Path | None) -> float:
    """Seconds between the run's consecutive /joint_states stamps (the report counts gaps on this grid)."""
    return 1.0 / nominal_rate(LOOPS[0], run_dir)


def loop_topic(loop: Loop, run_dir: Path | None) -> str:
    """The stream that shows ``loop`` in this run (module docstring: the driver twins publish the drivers' topics)."""
    if run_dir is not None and loop.driver_topic is not None and \
            _parameters(run_dir / "params" / loop.params_file).get("driver_interface") == loop.driver_interface:
        return loop.driver_topic
    return loop.topic


def _receive_times(bag: Path, topics: set[str]) -> tuple[dict[str, list[int]], tuple[int, int] | None]:
    """The recorder's receive times [ns] of ``topics`` in one bag, and the span of every message in it."""
    times: dict[str, list[int]] = {}
    first = last = None
    for _, channel, message in read_messages(bag):
        first = message.log_time if first is None else min(first, message.log_time)
        last = message.log_time if last is None else max(last, message.log_time)
        if channel.topic in topics:
            times.setdefault(channel.topic, []).append(message.log_time)
    return times, (first, last) if first is not None else None


def loop_topics(run_dir: Path | None = None) -> set[str]:
    """The streams that show this run's loops (loop_topic of each)."""
    return {loop_topic(loop, run_dir) for loop in LOOPS}


def loop_rates(bag: Path, run_dir: Path | None = None, skip_s: float = 3.0, tail_s: float = 1.0,
               receive_times: tuple[dict[str, list[int]], tuple[int, int] | None] | None = None) -> dict[str, dict]:
    """{loop: {topic, nominal_hz, achieved_hz, fraction}} of one run (module docstring). ``receive_times``: the
    bag's receive times of loop_topics and its span, when the caller has read them already (the launcher reads the
    bag once for all its figures, fic_teleop_bringup/run_bag.py); None: read here."""
    topics = {loop: loop_topic(loop, run_dir) for loop in LOOPS}
    master_bag = [run_dir / "bag_master"] if run_dir is not None and (run_dir / "bag_master").exists() else []
    recorded = [receive_times if receive_times is not None else _receive_times(bag, set(topics.values()))] + \
        [_receive_times(path, set(topics.values())) for path in master_bag]
    if recorded[0][1] is None:
        return {}
    rates: dict[str, dict] = {}
    for loop in LOOPS:
        topic = topics[loop]
        # the bag that holds the stream (the robot station's first), over that bag's own span
        times, span = next(((times, span) for times, span in recorded if times.get(topic)), recorded[0])
        start, end = span[0] + skip_s * 1e9, span[1] - tail_s * 1e9
        stamps = np.asarray(times.get(topic, []), dtype=np.int64)
        inside = stamps[(stamps >= start) & (stamps <= end)]
        nominal = nominal_rate(loop, run_dir)
        achieved = len(inside) / ((end - start) * 1e-9) if end > start else float("nan")
        rates[loop.name] = {"topic": topic, "nominal_hz": nominal, "achieved_hz": round(achieved, 1),
                            "fraction": round(achieved / nominal, 3) if nominal > 0 else None}
    return rates
