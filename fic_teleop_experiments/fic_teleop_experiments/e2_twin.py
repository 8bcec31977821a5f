"""Tune the E2 operator script on the in-process graph (NOT an experiment result).

    python -m fic_teleop_experiments.e2_twin [--script config/operator_scripts/shape_sorting.yaml] [--seed 1] [--tune N]

The graph in lockstep runs at 0.1-0.3x real time on this shared 2-core machine; tuning the shape-sorting script
against it costs ~10 minutes a try. This runs the script on fic_teleop_experiments.in_process, which steps the same
core objects the nodes wrap (fic_core.MasterStation, Channel, fic_core.ReplicaLoop, the MuJoCo Panda with the
adhesive bond) in one process, and tells where the script's moves land; every reported E2 figure comes from the
real graph (scripts/experiments.sh).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import yaml

from fic_teleop_experiments.in_process import RunConfig, run as run_graph
from fic_teleop_experiments.shape_sorting import PIECE_NAMES, inside_box
from sim_bridge.device.virtual_operator import load_script

REPO = Path(__file__).resolve().parents[2]


def run(script_path: Path, seed: int, delay: float, duration: float | None, verbose: bool) -> dict:
    duration = duration or load_script(script_path).duration + 1.0
    result = run_graph(RunConfig(scene="shape_sorting", duration=duration, delay=delay, seed=seed,
                                 script_path=script_path))
    outcome = {name: {"inside": inside_box(result.objects[name][0]),
                      "position": np.round(result.objects[name][0], 4).tolist()} for name in PIECE_NAMES}
    log = {"t": result.time, "xd": result.desired, "x": result.tcp, "force": result.force, "offset": result.offset}
    return {"outcome": outcome, "log": log, "wall_s": result.wall_s, "limit_violations": result.limit_violations,
            "shaped": result.shaped_ticks}


def tune(args) -> int:
    from sim_bridge.device.operator_scripts import shape_sorting_script
    from sim_bridge.device.virtual_operator import script_to_mapping
    from sim_bridge.device.operator_scripts import _plain

    corrections = {}
    overrides = yaml.safe_load(args.overrides.read_text()) if args.overrides else {}
    if args.corrections and args.corrections.exists():
        corrections = {k: np.asarray(v, float) for k, v in (yaml.safe_load(args.corrections.read_text()) or {}).items()}
    for iteration in range(args.tune):
        script = shape_sorting_script({**overrides, "leg_corrections": {k: v.tolist() for k, v in corrections.items()}})
        path = Path(f"/tmp/e2_twin_tune_{iteration}.yaml")
        path.write_text(yaml.safe_dump(_plain(script_to_mapping(script)), sort_keys=False))
        result = run(path, args.seed, args.delay, args.duration, verbose=True)
        log = result["log"]
        print(f"iteration {iteration}: " + ", ".join(f"{n}: {'IN' if o['inside'] else 'out'}"
                                                    for n, o in result["outcome"].items()))
        # miss_k = miss_(k-1) + c_k + d_k (d_k: what leg k, and the offset-mode phase before it, add): each leg's
        # correction takes out its own increment, so upstream misses are not counted twice.
        previous = np.zeros(3)
        np.savez(f"/tmp/e2_twin_tune_{iteration}.npz", **log)
        for key, (t_end, *planned) in script.parameters["leg_ends"].items():
            realized = np.array([np.interp(t_end + args.delay, log["t"], log["offset"][:, a]) for a in range(3)])
            miss = realized - np.asarray(planned)
            corrections[key] = corrections.get(key, np.zeros(3)) - args.gain * (miss - previous)
            previous = miss
            print(f"  {key:28s} miss {np.round(miss * 1000, 1)} mm")
        if args.corrections:
            args.corrections.write_text(yaml.safe_dump({k: np.round(v, 5).tolist() for k, v in corrections.items()}))
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--script", type=Path, default=REPO / "config" / "operator_scripts" / "shape_sorting.yaml")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--delay", type=float, default=0.2)
    parser.add_argument("--duration", type=float, default=None)
    parser.add_argument("--plot", type=Path, default=None)
    parser.add_argument("--tune", type=int, default=0,
                        help="iterations of travel-leg correction: generate the script with the corrections so far, "
                             "run it, move each leg's end by minus the miss of x_d' there; prints the corrections")
    parser.add_argument("--corrections", type=Path, default=None, help="YAML of leg corrections to start from / write")
    parser.add_argument("--overrides", type=Path, default=None, help="YAML of generator parameters to override")
    parser.add_argument("--gain", type=float, default=0.5, help="share of a leg's own miss corrected per iteration")
    args = parser.parse_args(argv)
    if args.tune:
        return tune(args)
    result = run(args.script, args.seed, args.delay, args.duration, verbose=True)
    print(f"wall {result['wall_s']:.1f} s; limit violations {result['limit_violations']}, shaped {result['shaped']}")
    for name, outcome in result["outcome"].items():
        print(f"  {name}: {'INSIDE' if outcome['inside'] else 'outside'} at {outcome['position']}")
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        log = result["log"]
        fig, axes = plt.subplots(4, 1, figsize=(12, 10), sharex=True)
        for axis, label in enumerate("xyz"):
            axes[axis].plot(log["t"], log["xd"][:, axis], label="x_d")
            axes[axis].plot(log["t"], log["x"][:, axis], label="x_R")
            axes[axis].set_ylabel(label)
        axes[0].legend(fontsize=7)
        axes[3].plot(log["t"], np.linalg.norm(log["force"], axis=1))
        axes[3].set_ylabel("|F|")
        fig.savefig(args.plot, dpi=80)
    return 0


if __name__ == "__main__":
    sys.exit(main())
