"""What the replica station adds to a joint state's work: per-state wall time of ReplicaStation (the stream guard,
the loop, the loop's own readiness check, the driver's command) against the bare loop path the same states take
(ReplicaLoop.joint_state, ReplicaLoop.ready, the driver's command), on a Pinocchio Panda holding the circle's
set-points, in interleaved blocks so that both sides see the same machine.

    source scripts/env.sh && python -m fic_teleop_experiments.tools.bench_station [--states 20000] [--block 500]
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import yaml

from fic_core.panda_description import NOMINAL_CONFIGURATION
from fic_core.replica_station import ReplicaStation

CONFIG = Path(__file__).resolve().parents[3] / "config" / "replica.yaml"
PERIOD = 0.001


def _values() -> dict:
    values = dict(yaml.safe_load(CONFIG.read_text())["/**"]["ros__parameters"])
    return {**values, "control_rate": 1000.0, "exchanged_energy_observer": False}


def bench(states: int, block: int) -> dict[str, dict[str, float]]:
    q0 = np.array(NOMINAL_CONFIGURATION, dtype=float)
    stations = {side: ReplicaStation(_values()) for side in ("station", "loop")}
    times: dict[str, list[float]] = {side: [] for side in stations}
    clocks = {side: 0.0 for side in stations}
    for start in range(0, states, block):
        for side, station in stations.items():
            loop, driver = station.loop, station.driver
            now = clocks[side]
            for k in range(start, min(start + block, states)):
                now += PERIOD
                # A small motion so that the law works (the phases, the posture), the same on both sides.
                q = q0 + 0.05 * np.sin(0.002 * k + np.arange(7))
                qd = 0.1 * np.cos(0.002 * k + np.arange(7))
                begin = time.perf_counter()
                if side == "station":
                    if station.admits_joint_state(now, now)[0]:
                        station.joint_state(now, now, q, qd, round(now * 1e9))
                else:
                    step = loop.ready(loop.joint_state(now, now, q, qd), now, now)
                    driver.command_to_send(step.torque, loop.robot)
                times[side].append(time.perf_counter() - begin)
            clocks[side] = now
    return {side: {"median_us": float(np.median(values) * 1e6), "p99_us": float(np.percentile(values, 99) * 1e6),
                   "states": len(values)} for side, values in times.items()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--states", type=int, default=20000)
    parser.add_argument("--block", type=int, default=500)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    result = bench(args.states, args.block)
    for side, figures in result.items():
        print(f"{side:8s} median {figures['median_us']:.1f} us  p99 {figures['p99_us']:.1f} us  "
              f"({figures['states']} states)")
    if args.json:
        args.json.write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
