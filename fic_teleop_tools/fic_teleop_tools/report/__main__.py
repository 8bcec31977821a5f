"""python -m fic_teleop_tools.report <bag> [--out DIR]: metrics.json, plots and a summary table of a recorded session,
and the run's two verdicts, stable and safe, with their reasons (fic_teleop_tools.verdict.run_verdict; verdict.json)."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import yaml

from fic_teleop_runtime.workspace import config_folder
from fic_teleop_tools.verdict.run_record import quiet_from

from .bag_data import BagData, BagReadError, load_bag
from .loop_rates import joint_states_period
from .metrics import ReportSettings
from .report import make_report, replica_config_defaults, summary_table


def one_way_delay(run_dir: Path | None) -> float:
    """The channel's one-way delay [s] as the run started it: the mean of its two directions' ``delay`` in the run
    folder's params (a launcher's run), else config/channel.yaml's."""
    def delay(path: Path) -> float | None:
        if not path.is_file():
            return None
        sections = yaml.safe_load(path.read_text()) or {}
        for section in sections.values():
            value = (section or {}).get("ros__parameters", {}).get("delay")
            if value is not None:
                return float(value)
        return None

    if run_dir is not None:
        found = [d for d in (delay(run_dir / "params" / f"channel_{side}.yaml") for side in ("forward", "backward"))
                 if d is not None]
        if found:
            return sum(found) / len(found)
    return delay(config_folder() / "channel.yaml") or 0.0


def print_verdict(bag: Path | BagData, out: Path, delay: float, tail_from: float | None = None) -> None:
    """The two verdicts of the session (a bag, or as the report's pass read it with ``joint_velocities``), printed
    and written to ``out``/verdict.json; a bag the verdict cannot judge gets one line saying why."""
    from fic_teleop_tools.verdict.run_verdict import VerdictInput, VerdictInputError, judge

    try:
        data = bag if isinstance(bag, BagData) else load_bag(bag, joint_velocities=True)
        verdict = judge(VerdictInput.from_bag_data(data, one_way_delay=delay, quiet_from=tail_from))
    except (VerdictInputError, ValueError) as error:
        print(f"[report] verdict: cannot judge this bag: {error}", file=sys.stderr)
        return
    print(f"[verdict] one-way delay {delay:g} s: {verdict.summary()}")
    out.mkdir(parents=True, exist_ok=True)
    (out / "verdict.json").write_text(json.dumps(verdict.as_dict(), indent=1, default=float) + "\n")


def main(argv: list[str] | None = None) -> int:
    defaults = ReportSettings(**replica_config_defaults())
    parser = argparse.ArgumentParser(prog="python -m fic_teleop_tools.report", description=__doc__)
    parser.add_argument("bag", type=Path, help="bag folder (rosbag2 layout) or .mcap file")
    parser.add_argument("--out", type=Path, default=None, help="report folder (default: <bag>_report next to it)")
    parser.add_argument("--warmup", type=float, default=defaults.warmup_s,
                        help="seconds at the start left out of error/force/latency figures (default %(default)s)")
    parser.add_argument("--f-max", type=float, default=defaults.max_force_n,
                        help="controller F_max [N] drawn on the force plot (default: config/replica.yaml)")
    parser.add_argument("--x-b", type=float, default=defaults.error_bound_m,
                        help="error bound x_b [m] drawn on the error plot (default %(default)s)")
    parser.add_argument("--render", action="store_true",
                        help="also render key frames of the arm from /joint_states (MuJoCo, offscreen)")
    parser.add_argument("--scene", default="superimposition",
                        help="scene drawn in the key frames (default %(default)s)")
    parser.add_argument("--key-frame-interval", type=float, default=5.0,
                        help="seconds of sim time between key frames (default %(default)s)")
    parser.add_argument("--real-time-factor-target", type=float, default=None,
                        help="least real-time factor the report judges (default: the report's own target, "
                             "metrics.TARGETS; the launcher passes its run profile's bound)")
    parser.add_argument("--delay", type=float, default=None,
                        help="one-way delay [s] the verdict judges against (default: the run folder's channel "
                             "params, else config/channel.yaml)")
    args = parser.parse_args(argv)
    if args.warmup < 0:
        parser.error("--warmup must be >= 0")
    if args.delay is not None and not args.delay >= 0.0:
        parser.error("--delay must be >= 0")
    if args.real_time_factor_target is not None and not 0.0 < args.real_time_factor_target <= 1.0:
        parser.error("--real-time-factor-target must be in (0, 1]")
    out = args.out or args.bag.with_name(args.bag.name.removesuffix(".mcap") + "_report")
    # A launcher's run folder holds the bag and the run's params (the joint states' rate, if not every step).
    run_dir = args.bag.parent if (args.bag.parent / "params").is_dir() else None
    settings = ReportSettings(warmup_s=args.warmup, max_force_n=args.f_max, error_bound_m=args.x_b,
                              joint_states_period_s=joint_states_period(run_dir),
                              real_time_factor_target=args.real_time_factor_target, quiet_from=quiet_from(run_dir))
    key_frame_interval = args.key_frame_interval if args.render else None
    try:
        # One pass over the bag for the report and its verdict (the joint velocities are the verdict's).
        data = load_bag(args.bag, keyframe_interval=key_frame_interval, joint_velocities=True)
        analysis, plots = make_report(args.bag, out, settings, key_frame_interval=key_frame_interval,
                                      scene=args.scene, data=data)
    except BagReadError as error:
        print(f"[report] cannot read the bag: {error}", file=sys.stderr)
        return 2
    except ImportError as error:  # only --render imports the simulator
        print(f"[report] --render needs the simulator package (sim_bridge, MuJoCo): {error}", file=sys.stderr)
        return 2
    metrics = analysis.metrics
    if not metrics["bag_complete"]:
        print("[report] note: the bag has no footer (recorder killed?); read up to its last complete chunk",
              file=sys.stderr)
    print(summary_table(metrics))
    print_verdict(data, out, args.delay if args.delay is not None else one_way_delay(run_dir), settings.quiet_from)
    print(f"[report] {out / 'metrics.json'}; plots: {', '.join(p.name for p in plots) or 'none'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
