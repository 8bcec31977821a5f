"""How long the arm ran on each torque, on its own clock, from a run's bag (docs/RESULTS.md, "Stress").

The replica's loop watch bounds the gap between its control ticks; the arm feels the time each torque stayed
applied, which a robot that steps its backlog in a burst makes longer. Two series, both on the arm's clock (the
joint-state stamps):

- applied: the time between two changes of the applied torque (the ``effort`` of /joint_states, the robot's
  applied torque); a hold of the robot's own watchdog changes it every step while the arm moves (its damping), a
  held command not (an arm held still by the watchdog reads as one long hold too);
- state gaps: between the joint states two consecutive torque commands were computed on (each command names its
  state, fic_core.command_stamp).

    python -m fic_teleop_experiments.tools.torque_hold runs/x [runs/y ...] [--bound-ms 50]
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from fic_core.command_stamp import stamp_ns


def torque_holds(run_dir: Path) -> tuple[np.ndarray, np.ndarray]:
    """(applied, state_gaps) [s] of the run in ``run_dir`` (its bag/ folder)."""
    from mcap_ros2.reader import read_ros2_messages

    states: list[tuple[float, tuple[float, ...]]] = []
    computed_on: list[float] = []
    for file in sorted((run_dir / "bag").glob("*.mcap")):
        for message in read_ros2_messages(str(file), topics=["/joint_states", "/effort_controller/commands"]):
            if message.channel.topic == "/joint_states":
                header = message.ros_msg.header.stamp
                states.append((header.sec + header.nanosec * 1e-9, tuple(message.ros_msg.effort[:7])))
            else:
                dims = message.ros_msg.layout.dim
                stamp = stamp_ns(dims[0].label) if dims else None
                if stamp is not None:
                    computed_on.append(stamp * 1e-9)
    states.sort()
    times = np.array([time for time, _ in states])
    efforts = np.array([effort for _, effort in states]).reshape(-1, 7)
    changed = np.flatnonzero(np.any(np.diff(efforts, axis=0) != 0.0, axis=1)) + 1
    applied = np.diff(times[changed]) if len(changed) > 1 else np.zeros(0)
    gaps = np.diff(np.sort(np.array(computed_on)))
    return applied, gaps[gaps > 0.0]


def summary(values: np.ndarray, bound: float) -> dict:
    if not len(values):
        return {"n": 0}
    return {"n": int(len(values)), "p50_ms": round(float(np.median(values)) * 1e3, 1),
            "p99_ms": round(float(np.percentile(values, 99)) * 1e3, 1), "max_ms": round(float(values.max()) * 1e3, 1),
            f"over_{bound * 1e3:g}_ms": int((values > bound).sum())}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", type=Path, help="run folders (each with a bag/)")
    parser.add_argument("--bound-ms", type=float, default=50.0, help="count the holds longer than this")
    args = parser.parse_args(argv)
    for run in args.runs:
        applied, gaps = torque_holds(run)
        bound = args.bound_ms * 1e-3
        print(json.dumps({"run": str(run), "applied": summary(applied, bound), "state_gaps": summary(gaps, bound)}))


if __name__ == "__main__":
    main()
