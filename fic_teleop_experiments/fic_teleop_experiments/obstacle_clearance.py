"""Closest approach of the Panda's hand and fingers to the superimposition scene's fixed obstacle, per lap.

Replays a run's recorded /joint_states in the scene's MuJoCo model (the simulator's own, sim_bridge.robot.mujoco_panda)
and measures the signed distance of every hand and finger geom to the obstacle with ``mj_geomDistance`` (negative:
penetration, i.e. a contact). One line per 5 s lap of the circle: the smallest distance, when, and where the hand
was. This is how the E1 operator script's margin over the obstacle was measured (docs/EXPERIMENTS.md).

    python -m fic_teleop_experiments.obstacle_clearance runs/<run>            # a run folder (or its bag folder)
    python -m fic_teleop_experiments.obstacle_clearance runs/<run> --every 5  # every 5th joint state (default 10)
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import mujoco
import numpy as np

from fic_core.panda_description import ARM_JOINT_NAMES
from fic_teleop_tools.recording.bag_reader import mcap_file
from sim_bridge.robot.mujoco_panda import build_model

HAND_BODIES = ("panda_hand", "panda_leftfinger", "panda_rightfinger")
OBSTACLE_GEOM = "fixed_obstacle"
LAP_S = 5.0          # the circle's period (config/planner.yaml, the paper's 5 s)
SEARCH_RANGE_M = 0.2  # mj_geomDistance looks this far; farther counts as "clear by more than this"


def joint_states(bag: Path, every: int):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with open(mcap_file(bag), "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for index, (_, _, _, message) in enumerate(reader.iter_decoded_messages(topics=["/joint_states"])):
            if index % every == 0:
                stamp = message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec
                yield stamp, dict(zip(message.name, message.position))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run", type=Path, help="run folder (with bag/) or bag folder")
    parser.add_argument("--every", type=int, default=10, help="use every n-th joint state (default 10: 100 Hz)")
    args = parser.parse_args(argv)
    bag = args.run / "bag" if (args.run / "bag").is_dir() else args.run
    model, _ = build_model("superimposition")
    data = mujoco.MjData(model)
    obstacle = model.geom(OBSTACLE_GEOM).id
    hand_geoms = [g for g in range(model.ngeom) if model.body(model.geom_bodyid[g]).name in HAND_BODIES]
    addresses = [model.jnt_qposadr[model.joint(name).id] for name in ARM_JOINT_NAMES]
    fromto = np.zeros(6)
    laps: dict[int, tuple[float, float, np.ndarray]] = {}
    start = None
    for stamp, positions in joint_states(bag, max(1, args.every)):
        start = stamp if start is None else start
        data.qpos[addresses] = [positions[name] for name in ARM_JOINT_NAMES]
        mujoco.mj_forward(model, data)
        distance = min(mujoco.mj_geomDistance(model, data, g, obstacle, SEARCH_RANGE_M, fromto) for g in hand_geoms)
        lap = int((stamp - start) // LAP_S)
        if lap not in laps or distance < laps[lap][1]:
            laps[lap] = (stamp - start, distance, data.body("panda_hand").xpos.copy())
    if not laps:
        print(f"no /joint_states in {bag}", file=sys.stderr)
        return 1
    print("lap  time [s]  closest [mm]  hand position [m]")
    for lap, (time, distance, position) in sorted(laps.items()):
        print(f"{lap:3d}  {time:8.2f}  {distance * 1000:12.1f}  {np.round(position, 3).tolist()}")
    contacts = sum(1 for _, distance, _ in laps.values() if distance <= 0.0)
    print(f"laps touching the obstacle: {contacts} of {len(laps)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
