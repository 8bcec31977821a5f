"""A graph run's channel ports against the in-process runner's (docs/RESULTS.md, "Passivity in the graph").

The graph's figures are its report's (metrics.json: the live observers' last /diagnostics, the bag's tracking
error); the runner's are those of ``RunConfig`` with the same scene, seed, delay and law, and of the same law
without TDPA, which says how much energy the scene makes the delay generate in the first place.

The command line runs one lockstep graph run and the same configuration in process and prints both side by side:

    python -m fic_teleop_experiments.graph_passivity --controller linear_tdpa --delay 1.0 --duration 8 --out /tmp/gp
    python -m fic_teleop_experiments.graph_passivity --controller fic --tdpa --delay 1.0 --duration 8 --out /tmp/gp_fic
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from fic_teleop_experiments.in_process import RunConfig, agreement, run


@dataclass
class PortComparison:
    graph_error_rms_m: float
    in_process_error_rms_m: float
    graph_balance_j: float | None           # E_out,M + E_out,R - E_in,M - E_in,R, the live observers'
    in_process_balance_j: float             # the same sum in one process (ChannelPorts.generated_energy)
    in_process_without_tdpa_j: float        # the same law, the passivity controllers off
    graph_report_generated_j: float | None  # channel_energy_generated_j (the signals before TDPA acts)
    graph_forward_generated_j: float | None
    graph_backward_generated_j: float | None
    graph_negative_ticks: int | None
    in_process_master_energy_j: float       # W at the master and the replica side at the end
    in_process_replica_energy_j: float


def compare(run_dir: Path, config: RunConfig) -> PortComparison:
    """The graph run in ``run_dir`` (the launcher's --out, with its report) against ``config`` run in process."""
    metrics = json.loads((Path(run_dir) / "report" / "metrics.json").read_text())
    with_ports = run(config)
    tdpa_on = config.tdpa or config.controller == "linear_tdpa"
    without = run(dataclasses.replace(config, tdpa=False, controller="linear_bounded"
                                      if config.controller == "linear_tdpa" else config.controller)) \
        if tdpa_on else with_ports
    compared = agreement(Path(run_dir) / "bag", with_ports)
    return PortComparison(compared.graph_error_rms, compared.in_process_error_rms,
                          metrics.get("channel_observed_generated_j"), float(with_ports.port_energy[-1, 2]),
                          float(without.port_energy[-1, 2]), metrics.get("channel_energy_generated_j"),
                          metrics.get("channel_forward_generated_j"), metrics.get("channel_backward_generated_j"),
                          metrics.get("channel_port_negative_ticks"), float(with_ports.port_energy[-1, 0]),
                          float(with_ports.port_energy[-1, 1]))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--controller", default="linear_tdpa", choices=["fic", "linear_bounded", "linear_tdpa"])
    parser.add_argument("--tdpa", action="store_true", help="TDPA around the law (linear_tdpa has it already)")
    parser.add_argument("--delay", type=float, default=1.0)
    parser.add_argument("--duration", type=float, default=8.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=Path, required=True, help="the graph run's folder (must not exist)")
    args = parser.parse_args(argv)
    launch = [sys.executable, "-m", "fic_teleop_bringup.teleop_launcher", "--out", str(args.out),
              "--duration", str(args.duration), "--delay", str(args.delay), "--seed", str(args.seed),
              "--controller", args.controller, "--time-mode", "lockstep", "--no-video", "--wall-limit", "1800",
              *(["--tdpa"] if args.tdpa else [])]
    graph = subprocess.run(launch, capture_output=True, text=True)
    if graph.returncode != 0:
        print(graph.stdout[-2000:] + graph.stderr[-2000:], file=sys.stderr)
        print(f"the graph run failed (exit {graph.returncode}); its folder: {args.out}", file=sys.stderr)
        return 1
    config = RunConfig(duration=args.duration, delay=args.delay, controller=args.controller, seed=args.seed,
                       tdpa=args.tdpa)
    print(json.dumps(dataclasses.asdict(compare(args.out, config)), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
